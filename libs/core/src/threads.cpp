#include "talus/core/threads.hpp"

#include <sched.h>

#include <charconv>
#include <cstdlib>
#include <cstring>
#include <thread>

namespace talus::core {
namespace {

unsigned slurm_cpus() {
  const char* text = std::getenv("SLURM_CPUS_PER_TASK");
  if (!text) return 0;
  unsigned value = 0;
  const char* end = text + std::strlen(text);
  const auto [ptr, err] = std::from_chars(text, end, value);
  return err == std::errc() && ptr == end && value <= 4096 ? value : 0;
}

unsigned affinity_cpus() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof set, &set) != 0) return 0;
  return static_cast<unsigned>(CPU_COUNT(&set));
}

}  // namespace

unsigned default_thread_count() {
  if (const unsigned n = slurm_cpus(); n > 0) return n;
  if (const unsigned n = affinity_cpus(); n > 0) return n;
  const unsigned n = std::thread::hardware_concurrency();
  return n > 0 ? n : 1;
}

std::string default_thread_source() {
  if (slurm_cpus() > 0) return "SLURM_CPUS_PER_TASK";
  if (affinity_cpus() > 0) return "affinity mask";
  return "hardware";
}

}  // namespace talus::core
