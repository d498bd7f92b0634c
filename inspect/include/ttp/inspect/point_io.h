// Point clouds of a measured piece: reading PCD through PCL's PCDReader
// (ascii, binary, binary_compressed, organised clouds whose NaN points are
// skipped), PLY (ascii / binary little endian, float or double properties) and
// text (.xyz, .txt, .csv) into double precision millimetres, and writing them
// back. Coordinates stay double end to end: CMM exports carry doubles and the
// figures are sub-micrometre differences on a 200 mm piece.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace ttp::inspect {

struct PointCloud {
  Eigen::Matrix3Xd xyz_mm;   // one point per column
  Eigen::Matrix3Xd normals;  // same size when has_normals
  bool has_normals = false;
  std::string source;                 // file name, for messages
  std::vector<std::string> warnings;  // non-fatal findings of the reader
  Eigen::Index size() const { return xyz_mm.cols(); }
};

enum class LengthUnit { kMillimetre, kMetre, kInch };
double MillimetresPer(LengthUnit unit);
// "mm", "m", "in"; throws InputError(source "--units") otherwise.
LengthUnit ParseLengthUnit(const std::string& text);

struct ReadOptions {
  LengthUnit units = LengthUnit::kMillimetre;
  // The user named the units: the metres-instead-of-millimetres check of
  // the inspection is then skipped.
  bool units_given = false;
};

enum class CloudFormat {
  kPcdAscii,
  kPcdBinary,
  kPlyAscii,
  kPlyBinary,
  kXyz,
  kCsv
};
constexpr CloudFormat kAllCloudFormats[] = {
    CloudFormat::kPcdAscii,  CloudFormat::kPcdBinary, CloudFormat::kPlyAscii,
    CloudFormat::kPlyBinary, CloudFormat::kXyz,       CloudFormat::kCsv};
const char* CloudFormatName(CloudFormat format);       // "pcd-ascii", ...
const char* CloudFormatExtension(CloudFormat format);  // ".pcd", ...

// Reads a cloud; the format comes from the content (a "ply" or PCD header),
// else from the extension (.xyz/.txt/.csv text). Throws InputError naming
// the file, the line (text) or element (binary) and the problem: unknown
// format, bad header, truncated data, NaN/inf, empty cloud, a limit of
// ttp/geometry/limits.h exceeded (points, fields, COUNT, record size,
// coordinates; checked before anything is allocated). Data after the
// declared vertices of a PLY is a warning.
PointCloud ReadPointCloud(const std::filesystem::path& path,
                          const ReadOptions& options = {});

// The same from bytes in memory; `source` names the data in errors and its
// extension stands for the file's.
PointCloud ParsePointCloud(std::string_view data, const std::string& source,
                           const ReadOptions& options = {});

// Asks the kernel to back a large, not yet touched buffer (a cloud's
// coordinates) with huge pages: a million-point cloud otherwise costs
// thousands of page faults. A hint only; harmless where unsupported.
void AdviseHugePages(void* data, size_t bytes);

// Writes the cloud atomically in millimetres; binary formats hold doubles.
void WritePointCloud(const std::filesystem::path& path, const PointCloud& cloud,
                     CloudFormat format);

}  // namespace ttp::inspect
