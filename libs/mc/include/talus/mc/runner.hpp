// SPDX-License-Identifier: MIT
#pragma once
#include <cstdint>
#include <functional>
#include <vector>

#include "talus/mc/realization.hpp"

namespace talus::mc {

/// Runs the realizations `indices` of `scene` on `threads` worker threads (0 = one per
/// hardware thread). Each finished result is handed to `on_done` on the calling thread,
/// one at a time, in completion order (which varies between runs; the results do not).
/// The first exception of a worker or of `on_done` stops the run (workers finish the
/// realization in hand) and is rethrown here.
void run_realizations(const Scene& scene, const std::vector<std::uint32_t>& indices,
                      unsigned threads, const std::function<void(RealizationResult&&)>& on_done);

}  // namespace talus::mc
