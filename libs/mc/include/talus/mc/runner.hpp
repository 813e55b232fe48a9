// SPDX-License-Identifier: MIT
#pragma once
#include <cstdint>
#include <functional>
#include <vector>

#include "talus/mc/realization.hpp"

namespace talus::mc {

/// Runs the realizations `indices` of `scene` on `threads` worker threads (0 =
/// core::default_thread_count(): Slurm's CPUs per task or the affinity mask). Each finished result is handed to `on_done` on the calling thread,
/// one at a time, in completion order (which varies between runs; the results do not).
/// The first exception of a worker or of `on_done` stops the run (workers finish the
/// realization in hand) and is rethrown here. `stop_asked`, when given, is polled on the
/// calling thread at least every 50 ms: once it returns true the realizations in hand
/// are abandoned within a few hundred steps each (not handed over) and the call returns
/// after handing over those already finished.
void run_realizations(const Scene& scene, const std::vector<std::uint32_t>& indices,
                      unsigned threads, const std::function<void(RealizationResult&&)>& on_done,
                      const std::function<bool()>& stop_asked = {});

/// Draws the release of every realization in `indices` on its realized terrain (on
/// `threads` threads, 0 = core::default_thread_count()) and throws the core::InputError of the
/// lowest failing index, if any: a release in the ground or off the terrain is refused
/// before any realization runs.
void check_releases(const Scene& scene, const std::vector<std::uint32_t>& indices, unsigned threads);

}  // namespace talus::mc
