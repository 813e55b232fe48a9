// SPDX-License-Identifier: MIT
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "talus/io/file_header.hpp"
#include "talus/mc/realization.hpp"

namespace talus::io {

/// One feature of a run's release zone (local frame, m): its parts as mc::ReleaseFeature
/// has them (a point: one list of one vertex; a line: one polyline; a polygon: its outer
/// ring, then its holes) and its probability of being drawn (-).
struct ReleaseArea {
  std::vector<std::vector<std::vector<std::array<double, 2>>>> parts;
  double probability = 0.0;
};

/// What a run file holds besides its records (layout: docs/formats.md, "Run file").
struct RunInfo {
  Provenance provenance;
  std::uint64_t realizations = 0;   ///< realizations of the whole scene (all shards)
  std::string shard = "0/1";        ///< "K/N": which realizations i ≡ K (mod N) the file holds
  std::vector<std::string> blocks;        ///< block names, indexed by Record::block
  std::vector<std::string> stop_classes;  ///< indexed by Record::stop_class
  std::vector<std::string> barriers;      ///< barrier names, indexed by Crossing::barrier
  std::vector<std::vector<std::array<double, 2>>> barrier_lines;  ///< plan polylines (m)
  mc::HazardGridSpec hazard;              ///< size 0 = no hazard map
  /// The terrain the run used: its fingerprint (io::terrain_fingerprint) and its path made
  /// absolute when the run started; empty in files of earlier versions.
  std::string terrain_fingerprint;
  std::string terrain_file;
  /// The terrain's origin shift (m): positions in the records, crossings, trajectories,
  /// barrier lines and the hazard grid are local; adding it gives input coordinates. Zero
  /// in files of earlier versions (read the terrain file's instead).
  std::array<double, 3> origin_shift = {0.0, 0.0, 0.0};
  double hazard_relative_accuracy = 0.01; ///< of the per-cell sketches (-)
  /// The release zone: "point", "line" or "polygon" (release.kind) and its features;
  /// empty in files of earlier versions.
  std::string release_kind;
  std::vector<ReleaseArea> release;
};

/// The run metadata of a scene run as shard `shard`.
RunInfo make_run_info(const mc::Scene& scene, const Provenance& provenance, const mc::Shard& shard);

/// The crash-safe journal of a run in progress, next to the output: a directory holding
/// the run's metadata (info.h5) and one file per chunk of finished realizations
/// (chunk-NNNNNNNN.h5), each written under a temporary name and renamed when complete.
/// A run killed at any moment, even inside a write, leaves only complete chunk files
/// (and a temporary the resume removes), so it loses at most the chunk in flight. The
/// output file is written from it at the end.
class RunJournal {
 public:
  /// Creates an empty journal at `path` (a directory; removed first if it exists).
  static RunJournal create(const std::string& path, const RunInfo& info);
  /// Reopens the journal of an interrupted run for appending. Throws core::InputError
  /// naming the journal if it is not one, or if its run_identity or shard differ from
  /// `info` (a resume must continue the same run; outputs.chunk may change).
  static RunJournal resume(const std::string& path, const RunInfo& info);

  /// Writes finished realizations (any order) as one more chunk file.
  void append(const std::vector<mc::RealizationResult>& chunk);
  /// Realizations already in the journal, ascending.
  std::vector<std::uint32_t> finished() const;
  /// Everything appended, in canonical order.
  mc::RunData read() const;
  const std::string& path() const { return path_; }
  /// Removes the journal (once the run file is written).
  void remove() const;

 private:
  RunJournal(std::string path, RunInfo info) : path_(std::move(path)), info_(std::move(info)) {}
  std::string path_;
  RunInfo info_;
  std::vector<std::string> chunks_;  ///< chunk file names, in writing order
  std::uint64_t next_chunk_ = 0;     ///< number of the next chunk file
  std::vector<std::uint32_t> done_;  ///< realizations in the chunk files
};

/// The journal path of an output ("run.h5" → "run.h5.journal").
std::string run_journal_path(const std::string& output);

/// Writes a run file atomically: header, provenance, run info, records sorted by
/// realization, barrier crossings, hazard accumulators, sampled trajectories (if any)
/// and, when there are trajectories, an XDMF sidecar (polylines) next to it.
void write_run_file(const std::string& path, const RunInfo& info, const mc::RunData& data);

struct RunFile {
  RunInfo info;
  mc::RunData data;
};
/// Reads a run file, checking the kind, schema version and array shapes; throws a
/// one-line core::InputError naming the file otherwise.
RunFile read_run_file(const std::string& path);

/// What files of one run share, as text (equal for its shards, its journal, and the run
/// file): the settings that change the records (every one but outputs.chunk, which only
/// sets how realizations are written), the inputs read, the realization count and the
/// terrain's fingerprint.
std::string run_identity(const RunInfo& info);

/// Joins shards of one run (same run_identity, disjoint shards) into one: the records of
/// realizations in ascending order, crossings and trajectories in the same order, hazard
/// accumulators merged exactly; the info (provenance included) is the first shard's.
/// Throws core::InputError naming the file that does not belong (and the first setting
/// that differs, or the inputs, realization count or terrain) or repeats realizations.
/// The result's shard is "0/1" when every realization of the run is present.
RunFile merge_run_files(const std::vector<RunFile>& shards, const std::vector<std::string>& names);

}  // namespace talus::io
