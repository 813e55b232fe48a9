// SPDX-License-Identifier: MIT
#pragma once
#include <string>

namespace talus::core {

/// The worker threads a run uses by default: SLURM_CPUS_PER_TASK when Slurm sets it,
/// otherwise the CPUs of this process's affinity mask (taskset, cpusets, cgroups), at
/// least 1. The thread count never changes results, only speed.
unsigned default_thread_count();

/// Where default_thread_count() took its count from, for logs: "SLURM_CPUS_PER_TASK",
/// "affinity mask" or "hardware".
std::string default_thread_source();

}  // namespace talus::core
