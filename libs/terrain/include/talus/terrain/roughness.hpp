// SPDX-License-Identifier: MIT
#pragma once

namespace talus::terrain {

/// σ (m) of the grid-point elevation shifts for a Römkens–Wang roughness index R (-).
///
/// R = A·F with A the micro-relief area index and F the peak frequency. The SPEC §2
/// reference table is given for a 2 m cell with F = 1/400 and σ = 2A mm, hence
/// A = 400 R and σ = 800 R mm = 0.8 R m:
///
///   R = 1/8 → σ = 0.1 m,  R = 1/4 → σ = 0.2 m,  R = 1/2 → σ = 0.4 m.
///
/// The mapping is the table's and holds for its 2 m cell; for other cell sizes give σ
/// directly. Throws core::InputError("roughness_index", …) unless R is finite and >= 0.
double sigma_from_roughness_index(double roughness_index);

}  // namespace talus::terrain
