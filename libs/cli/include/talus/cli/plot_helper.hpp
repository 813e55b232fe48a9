// SPDX-License-Identifier: MIT
#pragma once
#include <string>
#include <utility>

namespace talus::cli {

/// The Python interpreter of the plot helper: $TALUS_PYTHON, else /usr/bin/python3
/// (Debian's, with python3-matplotlib and python3-h5py).
std::string python_interpreter();

/// The plot helper `talus-plot`: $TALUS_PLOT, else the one next to the running executable.
std::string plot_helper();

/// Throws core::RuntimeError, naming the fix (install, TALUS_PYTHON, TALUS_PLOT, or
/// --set plots=false), when the interpreter cannot import matplotlib, h5py and numpy or
/// the helper is missing: checked before any work, so a long run does not fail at its end.
void check_plotting();

/// Runs `talus-plot ARGUMENTS` (arguments already quoted with shell_quote); throws
/// core::RuntimeError with the helper's last line of stderr when it fails.
void run_plot_helper(const std::string& arguments);

/// `s` quoted for a POSIX shell.
std::string shell_quote(const std::string& s);

}  // namespace talus::cli
