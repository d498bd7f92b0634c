// Any measurement of a finished piece (measurements.md), read into one
// shape: per-feature results on the nominal model, the figures E_X..E_TTP
// computed from them, and the inspection JSON.
//
// Formats, recognised from the content (then the extension):
// - point clouds (PLY, PCD, .xyz/.txt/.csv with three numbers per line):
//   aligned, segmented and fitted by InspectCloud;
// - an inspection JSON written by `ttp inspect --json` (or any JSON with the
//   "facets"/"strips" keys of that format);
// - the dial-gauge CSV (header `feature,reading_um`);
// - a DMIS output file (FA(...) = FEAT/...);
// - the probe results CSV of `ttp plan probe` (header starting `point_id`).
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "ttp/geometry/config.h"
#include "ttp/inspect/dial.h"
#include "ttp/inspect/dmis.h"
#include "ttp/inspect/inspect.h"
#include "ttp/inspect/probe.h"

namespace ttp::inspect {

enum class MeasurementKind { kCloud, kInspectionJson, kDial, kDmis, kProbe };
const char* MeasurementKindName(MeasurementKind kind);  // "cloud", ...

struct MeasurementOptions {
  ReadOptions read;        // cloud units
  InspectOptions inspect;  // cloud inspection rules, instrument
  DialOptions dial;        // gauge resolution and repeatability
  ProbeReadOptions probe;  // probe repeatability, point list
  DmisImportOptions dmis;  // the CMM's MPE and touches behind DMIS planes
  // Ceres style: the first invalid member's message, prefixed
  // "MeasurementOptions.<member>." (the point reader's options check
  // themselves when read).
  bool IsValid(std::string* error) const;
};

struct Measurement {
  std::string source;  // the file
  MeasurementKind kind = MeasurementKind::kCloud;
  // features, figures, extras and warnings are always filled; alignment and
  // segmentation only for clouds.
  InspectionResult result;
};

// Throws InputError naming the file, line and field for anything it cannot
// read (unknown format, bad values, a file that is not a test piece).
Measurement LoadMeasurement(const Config& config,
                            const std::filesystem::path& path,
                            const MeasurementOptions& options = {});

// The kind of measurement `head` (the file's first bytes) holds: PLY/PCD
// header -> cloud, '{' -> JSON, DMISMN / FA( -> DMIS, a header starting
// point_id -> probe, feature + reading_um -> dial; then the extension
// (.json, .dmi/.dmo/.dmis); else a text cloud.
MeasurementKind SniffMeasurement(const std::string& head,
                                 const std::filesystem::path& path);

// "thermal-log" or "talc-log" when `head` (a file's first bytes) opens
// with the `# key: value` header of such a log (thermal-log.md,
// talc-log.md: the format's key among the leading comment lines, in any
// order); "" otherwise. LoadMeasurement refuses such a file naming what it
// is and where it goes.
std::string SniffLogFormat(const std::string& head);

// InspectionToJson plus "kind" (no "alignment" unless a cloud).
nlohmann::json MeasurementToJson(const Measurement& m);

}  // namespace ttp::inspect
