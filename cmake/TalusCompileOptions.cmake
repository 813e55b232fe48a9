# Compile options shared by every Talus target, applied through talus_configure_target().

# Floating-point results must not depend on whether the compiler fuses a*b+c: the same
# inputs and seed give the same bits on every machine.
add_compile_options(-ffp-contract=off)

if(TALUS_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
endif()

function(talus_configure_target target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Wconversion
                         -Wno-sign-conversion)
  if(TALUS_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
