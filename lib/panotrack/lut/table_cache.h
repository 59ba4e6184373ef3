// An on-disk cache of E(D, Z) tables, so that a run does not rebuild the
// table its calibration and map need (hundreds of milliseconds, more than a
// short clip takes to track). Tables live in a cache folder of the user
// (DefaultTableCacheDir) rather than beside the calibration, which is often
// read-only (a system install, a mounted data set).
//
// A cached table's file name carries a key: a checksum of everything the
// table depends on (sensor model, image size and parameters, distance and
// height ranges, which come from the map and its sensor_height, the table's
// node counts, the file format and the build's version). The file is written
// in the lookup table format (radius_table.h, with its own checksum), to a
// temporary file renamed into place, so that runs in parallel never see a
// partial table: the last writer wins with identical content. A file that
// fails to load (truncated, corrupt, another format) or holds another
// table's parameters is never trusted: it is reported, rebuilt and replaced.
#pragma once

#include <functional>
#include <string>

#include "panotrack/lut/radius_table.h"

namespace pano {

// $XDG_CACHE_HOME/panotrack, else $HOME/.cache/panotrack; empty when neither
// variable is set (no cache).
std::string DefaultTableCacheDir();

// 16 hexadecimal digits naming the table Build(sensor, ranges, size) makes.
std::string RadiusTableCacheKey(const Sensor& sensor, const LutRanges& ranges, const LutSize& size);

// The cache file of that table in `dir`.
std::string RadiusTableCachePath(const std::string& dir, const Sensor& sensor, const LutRanges& ranges,
                                 const LutSize& size);

struct TableCacheOptions {
  std::string dir;  // cache folder (created when missing); empty: no cache, always build
  // Unexpected events: a cached file rejected, the folder or file not
  // writable (the run goes on with the table it built). Empty: silent.
  std::function<void(const std::string&)> on_note;
  // Routine events: hit, miss, file written. Empty: silent.
  std::function<void(const std::string&)> on_trace;
};

enum class TableCacheOutcome {
  kDisabled,  // no cache folder: built
  kHit,       // loaded from the cache
  kBuilt,     // missing or rejected: built and stored
  kNotStored  // built; storing it failed (see on_note)
};

// The table Build(sensor, ranges, size, num_threads) returns, from the cache
// when it holds a valid copy (bit-identical to a fresh build), else built
// and stored. Throws pano::Error only for what Build throws for.
RadiusTable LoadOrBuildRadiusTable(const Sensor& sensor, const LutRanges& ranges, const LutSize& size,
                                   const TableCacheOptions& cache, TableCacheOutcome* outcome = nullptr,
                                   int num_threads = 0);

}  // namespace pano
