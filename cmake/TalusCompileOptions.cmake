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
  # GCC 12 reports -Wrestrict for `"text" + std::string` inside std::string itself
  # (GCC bug 105329), a false positive that -Werror would turn into a failed build.
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13)
    target_compile_options(${target} PRIVATE -Wno-restrict)
  endif()
  if(TALUS_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
