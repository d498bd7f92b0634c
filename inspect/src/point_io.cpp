#include "ttp/inspect/point_io.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <pcl/PCLPointCloud2.h>
#include <pcl/io/pcd_io.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <string_view>

#include "quiet_pcl.h"
#include "ttp/geometry/csv.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/file_io.h"
#include "ttp/geometry/limits.h"

namespace ttp::inspect {
namespace {

// The file mapped read-only (clouds run to hundreds of megabytes: no copy,
// no zero fill; MAP_POPULATE maps the cached pages in one go).
class MappedFile {
 public:
  explicit MappedFile(const std::filesystem::path& path) {
    const int fd = ::open(path.c_str(), O_RDONLY);
    if (fd < 0) throw InputError(path.string(), 0, "", "cannot open the file");
    struct stat st {};
    if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
      ::close(fd);
      throw InputError(path.string(), 0, "", "not a readable regular file");
    }
    size_ = static_cast<size_t>(st.st_size);
    if (size_ > 0) {
      void* m =
          ::mmap(nullptr, size_, PROT_READ, MAP_PRIVATE | MAP_POPULATE, fd, 0);
      if (m == MAP_FAILED) {
        ::close(fd);
        throw InputError(path.string(), 0, "", "cannot read the file");
      }
      data_ = static_cast<const char*>(m);
    }
    ::close(fd);
  }
  ~MappedFile() {
    if (data_) ::munmap(const_cast<char*>(data_), size_);
  }
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;
  std::string_view view() const { return {data_ ? data_ : "", size_}; }

 private:
  const char* data_ = nullptr;
  size_t size_ = 0;
};

// Splits a header line into words.
std::vector<std::string> Words(const std::string& line) {
  std::istringstream ss(line);
  std::vector<std::string> w;
  std::string s;
  while (ss >> s) w.push_back(s);
  return w;
}

// Reads the next '\n'-terminated line from `data` at `*pos`.
bool NextLine(std::string_view data, size_t* pos, std::string* line) {
  if (*pos >= data.size()) return false;
  size_t end = data.find('\n', *pos);
  if (end == std::string::npos) end = data.size();
  line->assign(data.substr(*pos, end - *pos));
  if (!line->empty() && line->back() == '\r') line->pop_back();
  *pos = end + 1;
  return true;
}

bool IsSeparator(char c) {
  return c == ' ' || c == '\t' || c == ',' || c == ';' || c == '\r';
}

// Parses the numbers of one text line (any of the separators); returns
// false on a token that is not a number.
bool ParseNumbers(const char* begin, const char* end, std::vector<double>* out,
                  std::string* bad_token) {
  out->clear();
  const char* p = begin;
  while (p < end) {
    while (p < end && IsSeparator(*p)) ++p;
    if (p >= end) break;
    const char* q = p;
    while (q < end && !IsSeparator(*q)) ++q;
    double v = 0;
    const char* start = (*p == '+') ? p + 1 : p;
    auto [ptr, ec] = std::from_chars(start, q, v);
    if (ec != std::errc() || ptr != q) {
      // from_chars rejects "nan"/"inf" spellings only sometimes; be explicit.
      *bad_token = std::string(p, q);
      std::string low = Lower(*bad_token);
      if (low == "nan" || low == "-nan" || low == "inf" || low == "-inf" ||
          low == "infinity") {
        out->push_back(std::numeric_limits<double>::quiet_NaN());
        p = q;
        continue;
      }
      return false;
    }
    out->push_back(v);
    p = q;
  }
  return true;
}

void CheckFinite(const std::string& source, int line, const std::string& what,
                 const double* v, int n) {
  for (int i = 0; i < n; ++i) {
    if (!std::isfinite(v[i])) {
      throw InputError(source, line, what,
                       "value is not a finite number (NaN or inf)");
    }
  }
}

// Coordinates beyond kMaxCoordinateMm (after scaling) are not a measured
// piece (1e300 would overflow every sum of squares downstream).
void CheckMagnitude(const std::string& source, const std::string& where,
                    const double* p, double scale) {
  for (int a = 0; a < 3; ++a) {
    if (std::abs(p[a] * scale) > limits::kMaxCoordinateMm)
      throw InputError(source, 0, where,
                       "coordinate " + std::to_string(p[a]) +
                           " is beyond the limit of " +
                           std::to_string(limits::kMaxCoordinateMm) + " mm");
  }
}

void FinishCloud(PointCloud* cloud, Eigen::Matrix3Xd&& xyz,
                 const std::vector<double>& nrm, double scale) {
  const Eigen::Index n = xyz.cols();
  if (n == 0) throw InputError(cloud->source, 0, "", "the cloud has no points");
  cloud->xyz_mm = std::move(xyz);
  if (scale != 1.0) cloud->xyz_mm *= scale;
  cloud->has_normals = static_cast<Eigen::Index>(nrm.size()) == 3 * n;
  if (cloud->has_normals)
    cloud->normals = Eigen::Map<const Eigen::Matrix3Xd>(nrm.data(), 3, n);
}

void FinishCloud(PointCloud* cloud, const std::vector<double>& xyz,
                 const std::vector<double>& nrm, double scale) {
  const Eigen::Index n = static_cast<Eigen::Index>(xyz.size() / 3);
  if (n == 0) throw InputError(cloud->source, 0, "", "the cloud has no points");
  cloud->xyz_mm = Eigen::Map<const Eigen::Matrix3Xd>(xyz.data(), 3, n) * scale;
  cloud->has_normals = nrm.size() == xyz.size();
  if (cloud->has_normals) {
    cloud->normals = Eigen::Map<const Eigen::Matrix3Xd>(nrm.data(), 3, n);
  }
}

// ---------------------------------------------------------------- text
PointCloud ReadText(std::string_view data, const std::string& source,
                    double scale) {
  PointCloud cloud;
  cloud.source = source;
  std::vector<double> xyz, nrm, nums;
  size_t pos = 0;
  int line_no = 0;
  int columns = -1;
  long count = -1;
  int count_line = 0;
  std::string bad;
  while (pos < data.size()) {
    size_t end = data.find('\n', pos);
    if (end == std::string::npos) end = data.size();
    ++line_no;
    const char* b = data.data() + pos;
    const char* e = data.data() + end;
    pos = end + 1;
    const char* hash = static_cast<const char*>(std::memchr(b, '#', e - b));
    if (hash) e = hash;
    if (!ParseNumbers(b, e, &nums, &bad)) {
      // A header row of names ("x,y,z") is allowed before any data.
      if (xyz.empty() && columns < 0 &&
          std::isalpha(
              static_cast<unsigned char>(bad.empty() ? '0' : bad[0]))) {
        const std::string low = Lower(std::string(b, e));
        if (low.find('x') != std::string::npos &&
            low.find('y') != std::string::npos) {
          continue;
        }
      }
      throw InputError(
          source, line_no, "",
          "'" + bad + "' is not a number (expected x y z [nx ny nz])");
    }
    if (nums.empty()) continue;
    // A first line with one whole number is the point count (.pts files,
    // NIST .ds data sets); it is checked at the end.
    if (nums.size() == 1 && xyz.empty() && columns < 0 && count < 0 &&
        nums[0] >= 0 && nums[0] == std::floor(nums[0])) {
      if (nums[0] > static_cast<double>(limits::kMaxCloudPoints))
        throw InputError(source, line_no, "point count",
                         "beyond the limit of " +
                             std::to_string(limits::kMaxCloudPoints) +
                             " points");
      count = static_cast<long>(nums[0]);
      count_line = line_no;
      continue;
    }
    if (nums.size() != 3 && nums.size() != 6) {
      throw InputError(
          source, line_no, "",
          "expected 3 (x y z) or 6 (x y z nx ny nz) numbers, got " +
              std::to_string(nums.size()) +
              (end >= data.size() ? " (truncated file?)" : ""));
    }
    if (columns < 0) columns = static_cast<int>(nums.size());
    if (static_cast<int>(nums.size()) != columns) {
      throw InputError(source, line_no, "",
                       "has " + std::to_string(nums.size()) +
                           " numbers where earlier lines have " +
                           std::to_string(columns));
    }
    CheckFinite(source, line_no, "x y z", nums.data(), columns);
    if (std::abs(nums[0] * scale) > limits::kMaxCoordinateMm ||
        std::abs(nums[1] * scale) > limits::kMaxCoordinateMm ||
        std::abs(nums[2] * scale) > limits::kMaxCoordinateMm)
      throw InputError(source, line_no, "x y z",
                       "a coordinate is beyond the limit of " +
                           std::to_string(limits::kMaxCoordinateMm) + " mm");
    if (static_cast<long long>(xyz.size() / 3) >= limits::kMaxCloudPoints)
      throw InputError(source, line_no, "",
                       "more than " + std::to_string(limits::kMaxCloudPoints) +
                           " points is beyond the limit");
    xyz.insert(xyz.end(), nums.begin(), nums.begin() + 3);
    if (columns == 6) nrm.insert(nrm.end(), nums.begin() + 3, nums.end());
  }
  if (count >= 0 && static_cast<long>(xyz.size() / 3) != count)
    throw InputError(source, count_line, "point count",
                     "says " + std::to_string(count) +
                         " points, the file has " +
                         std::to_string(xyz.size() / 3) + " (truncated?)");
  FinishCloud(&cloud, xyz, nrm, scale);
  return cloud;
}

// ---------------------------------------------------------------- binary
long long HeaderInteger(const std::string& word, const std::string& source,
                        int line, const std::string& key, long long max) {
  long long v = 0;
  const auto [ptr, ec] =
      std::from_chars(word.data(), word.data() + word.size(), v);
  if (ec != std::errc() || ptr != word.data() + word.size() || v < 0)
    throw InputError(source, line, key,
                     "'" + word + "' is not a whole number >= 0");
  if (v > max)
    throw InputError(source, line, key,
                     word + " is beyond the limit of " + std::to_string(max));
  return v;
}

int TypeSize(const std::string& t) {
  if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
  if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
  if (t == "int" || t == "uint" || t == "int32" || t == "uint32" ||
      t == "float" || t == "float32")
    return 4;
  if (t == "double" || t == "float64") return 8;
  return 0;
}

double ReadScalar(const char* p, const std::string& t) {
  auto get = [p](auto v) {
    std::memcpy(&v, p, sizeof v);
    return static_cast<double>(v);
  };
  if (t == "double" || t == "float64") return get(double{});
  if (t == "float" || t == "float32") return get(float{});
  if (t == "int" || t == "int32") return get(int32_t{});
  if (t == "uint" || t == "uint32") return get(uint32_t{});
  if (t == "short" || t == "int16") return get(int16_t{});
  if (t == "ushort" || t == "uint16") return get(uint16_t{});
  if (t == "char" || t == "int8") return get(int8_t{});
  return get(uint8_t{});
}

struct Property {
  std::string name, type;
  int offset = 0;
};

// Indices of x y z (and nx ny nz) among the properties; -1 if absent.
void FindXyz(const std::vector<Property>& props, int xyz[3], int nrm[3],
             const char* nx, const char* ny, const char* nz) {
  const char* names[3] = {"x", "y", "z"};
  const char* nnames[3] = {nx, ny, nz};
  for (int a = 0; a < 3; ++a) {
    xyz[a] = nrm[a] = -1;
    for (size_t i = 0; i < props.size(); ++i) {
      if (props[i].name == names[a]) xyz[a] = static_cast<int>(i);
      if (props[i].name == nnames[a]) nrm[a] = static_cast<int>(i);
    }
  }
}

// ---------------------------------------------------------------- PLY
PointCloud ReadPly(std::string_view data, const std::string& source,
                   double scale) {
  PointCloud cloud;
  cloud.source = source;
  size_t pos = 0;
  std::string line;
  int line_no = 0;
  std::string format;
  struct Element {
    std::string name;
    long long count = 0;
    std::vector<Property> props;
    bool has_list = false;
    int stride = 0;
  };
  std::vector<Element> elements;
  bool ended = false;
  while (NextLine(data, &pos, &line)) {
    ++line_no;
    auto w = Words(line);
    if (line_no == 1) {
      if (w.empty() || w[0] != "ply") {
        throw InputError(source, 1, "header", "PLY file must start with 'ply'");
      }
      continue;
    }
    if (w.empty() || w[0] == "comment" || w[0] == "obj_info") continue;
    if (w[0] == "format") {
      if (w.size() < 2) throw InputError(source, line_no, "format", "missing");
      format = w[1];
    } else if (w[0] == "element") {
      if (w.size() != 3) {
        throw InputError(source, line_no, "element",
                         "expected 'element NAME COUNT'");
      }
      Element e;
      e.name = w[1];
      e.count = HeaderInteger(w[2], source, line_no, "element " + e.name,
                              limits::kMaxCloudPoints);
      elements.push_back(e);
    } else if (w[0] == "property") {
      if (elements.empty()) {
        throw InputError(source, line_no, "property",
                         "property before any element");
      }
      Element& e = elements.back();
      if (w.size() >= 2 && w[1] == "list") {
        e.has_list = true;
        continue;
      }
      if (w.size() != 3 || TypeSize(w[1]) == 0) {
        throw InputError(source, line_no, "property",
                         "expected 'property TYPE NAME' with a PLY type");
      }
      e.props.push_back({w[2], w[1], e.stride});
      e.stride += TypeSize(w[1]);
      if (e.props.size() > static_cast<size_t>(limits::kMaxCloudFields))
        throw InputError(source, line_no, "element " + e.name,
                         "more than " +
                             std::to_string(limits::kMaxCloudFields) +
                             " properties is beyond the limit");
    } else if (w[0] == "end_header") {
      ended = true;
      break;
    } else {
      throw InputError(source, line_no, "header",
                       "unknown PLY header line '" + line + "'");
    }
  }
  if (!ended)
    throw InputError(source, line_no, "header",
                     "no end_header (truncated header)");
  if (format != "ascii" && format != "binary_little_endian") {
    throw InputError(source, 0, "format",
                     format.empty() ? "missing format line"
                                    : "unsupported PLY format '" + format +
                                          "' (ascii or binary_little_endian)");
  }
  // The vertex element must come first or after fixed-size elements.
  size_t skip_bytes = 0;
  long long skip_lines = 0;
  const Element* vertex = nullptr;
  for (const Element& e : elements) {
    if (e.name == "vertex") {
      vertex = &e;
      break;
    }
    if (e.has_list && format != "ascii") {
      throw InputError(source, 0, "element " + e.name,
                       "list element before the vertices is not supported");
    }
    skip_bytes += static_cast<size_t>(e.stride) * e.count;
    skip_lines += e.count;
  }
  if (vertex == nullptr)
    throw InputError(source, 0, "element vertex", "missing");
  if (vertex->has_list) {
    throw InputError(source, 0, "element vertex",
                     "list properties not supported");
  }
  int ix[3], in[3];
  FindXyz(vertex->props, ix, in, "nx", "ny", "nz");
  for (int a = 0; a < 3; ++a) {
    if (ix[a] < 0) {
      throw InputError(source, 0, "element vertex",
                       std::string("no property ") + "xyz"[a]);
    }
  }
  const bool normals = in[0] >= 0 && in[1] >= 0 && in[2] >= 0;
  const long long n = vertex->count;
  if (n <= 0)
    throw InputError(source, 0, "element vertex", "the cloud has no points");
  // The data must be there before anything is allocated for it: binary
  // records of `stride` bytes, ascii lines of at least two bytes a value.
  const size_t body = data.size() - std::min(pos, data.size());
  const size_t least_bytes =
      format == "binary_little_endian"
          ? static_cast<size_t>(vertex->stride) * static_cast<size_t>(n)
          : 2 * vertex->props.size() * static_cast<size_t>(n);
  if (body < least_bytes)
    throw InputError(source, 0, "element vertex",
                     "truncated: header declares " + std::to_string(n) +
                         " vertices, the file is too short to hold them (" +
                         std::to_string(body) + " bytes of data)");
  // Straight into the cloud's matrix (no zero fill, no second copy).
  Eigen::Matrix3Xd xyz_m(3, n);
  AdviseHugePages(xyz_m.data(), sizeof(double) * 3 * n);
  double* xyz = xyz_m.data();
  std::vector<double> nrm(normals ? 3 * n : 0);
  if (format == "binary_little_endian") {
    const size_t start = pos + skip_bytes;
    const size_t stride = vertex->stride;
    if (data.size() < start + stride * n) {
      const long long have =
          data.size() < start
              ? 0
              : static_cast<long long>((data.size() - start) / stride);
      throw InputError(source, 0, "vertex " + std::to_string(have),
                       "truncated: header declares " + std::to_string(n) +
                           " vertices, data holds " + std::to_string(have));
    }
    const bool last = vertex == &elements.back();
    if (last && data.size() > start + stride * n)
      cloud.warnings.push_back(
          std::to_string(data.size() - start - stride * n) +
          " bytes after the " + std::to_string(n) +
          " declared vertices were ignored (is the vertex count right?)");
    const char* base = data.data() + start;
    const bool all_double =
        vertex->props[ix[0]].type == "double" &&
        vertex->props[ix[1]].type == "double" &&
        vertex->props[ix[2]].type == "double" &&
        vertex->props[ix[1]].offset == vertex->props[ix[0]].offset + 8 &&
        vertex->props[ix[2]].offset == vertex->props[ix[0]].offset + 16;
    for (long long i = 0; i < n; ++i) {
      const char* rec = base + i * stride;
      double* p = xyz + 3 * i;
      if (all_double) {
        std::memcpy(p, rec + vertex->props[ix[0]].offset, 24);
      } else {
        for (int a = 0; a < 3; ++a) {
          p[a] = ReadScalar(rec + vertex->props[ix[a]].offset,
                            vertex->props[ix[a]].type);
        }
      }
      if (!std::isfinite(p[0]) || !std::isfinite(p[1]) ||
          !std::isfinite(p[2])) {
        throw InputError(source, 0, "vertex " + std::to_string(i),
                         "coordinate is not a finite number (NaN or inf)");
      }
      if (normals) {
        for (int a = 0; a < 3; ++a) {
          nrm[3 * i + a] = ReadScalar(rec + vertex->props[in[a]].offset,
                                      vertex->props[in[a]].type);
        }
      }
    }
  } else {
    for (long long i = 0; i < skip_lines; ++i) {
      if (!NextLine(data, &pos, &line)) break;
      ++line_no;
    }
    std::vector<double> nums;
    std::string bad;
    for (long long i = 0; i < n; ++i) {
      if (!NextLine(data, &pos, &line)) {
        throw InputError(source, line_no + 1, "vertex " + std::to_string(i),
                         "truncated: header declares " + std::to_string(n) +
                             " vertices, file holds " + std::to_string(i));
      }
      ++line_no;
      if (!ParseNumbers(line.data(), line.data() + line.size(), &nums, &bad)) {
        throw InputError(source, line_no, "vertex " + std::to_string(i),
                         "'" + bad + "' is not a number");
      }
      if (nums.size() != vertex->props.size()) {
        throw InputError(source, line_no, "vertex " + std::to_string(i),
                         "expected " + std::to_string(vertex->props.size()) +
                             " values, got " + std::to_string(nums.size()));
      }
      for (int a = 0; a < 3; ++a) xyz[3 * i + a] = nums[ix[a]];
      CheckFinite(source, line_no, "vertex " + std::to_string(i), &xyz[3 * i],
                  3);
      if (normals) {
        for (int a = 0; a < 3; ++a) nrm[3 * i + a] = nums[in[a]];
      }
    }
    if (vertex == &elements.back()) {
      long long extra = 0;
      const int first_extra = line_no + 1;
      while (NextLine(data, &pos, &line))
        if (!Trim(line).empty()) ++extra;
      if (extra > 0)
        cloud.warnings.push_back(
            std::to_string(extra) + " lines from line " +
            std::to_string(first_extra) + " after the " + std::to_string(n) +
            " declared vertices were ignored (is the vertex count right?)");
    }
  }
  for (long long i = 0; i < n; ++i)
    CheckMagnitude(source, "vertex " + std::to_string(i), xyz + 3 * i, scale);
  FinishCloud(&cloud, std::move(xyz_m), nrm, scale);
  return cloud;
}

// ---------------------------------------------------------------- PCD
// The header is checked here (every limit before PCL allocates anything:
// PCL sizes its buffer from FIELDS x COUNT x SIZE x POINTS), then PCL's
// PCDReader reads it (ascii, binary, binary_compressed; organised clouds)
// into a PCLPointCloud2, whose x y z (and normals) are read field by field
// in their own type: double stays double. PCL is not given the file's
// header but one written again from what was checked: PCL splits words and
// matches keys by other rules (key prefixes, other whitespace, repeated
// lines each acted on), and a header that reads one way here and another
// way there could size PCL's buffer past every limit.

// A read-only istream over memory (PCL reads its header from a stream and
// asks where the body starts with tellg).
class MemoryBuffer : public std::streambuf {
 public:
  MemoryBuffer(const char* begin, const char* end) {
    char* b = const_cast<char*>(begin);
    setg(b, b, const_cast<char*>(end));
  }

 protected:
  pos_type seekoff(off_type off, std::ios_base::seekdir dir,
                   std::ios_base::openmode which) override {
    if (!(which & std::ios_base::in)) return pos_type(off_type(-1));
    char* target = dir == std::ios_base::beg   ? eback() + off
                   : dir == std::ios_base::cur ? gptr() + off
                                               : egptr() + off;
    if (target < eback() || target > egptr()) return pos_type(off_type(-1));
    setg(eback(), target, egptr());
    return pos_type(target - eback());
  }
  pos_type seekpos(pos_type pos, std::ios_base::openmode which) override {
    return seekoff(off_type(pos), std::ios_base::beg, which);
  }
};

using internal::QuietPcl;  // PCL is kept quiet while it reads

// The header checks; returns the body offset.
struct PcdHeader {
  long long points = 0, width = 0, height = 1, stride = 0;
  std::string data_kind;
  size_t body = 0;      // offset of the point data in the file
  std::string for_pcl;  // the checked header, written again for PCL
};

PcdHeader CheckPcdHeader(std::string_view data, const std::string& source) {
  PcdHeader h;
  size_t pos = 0;
  std::string line;
  int line_no = 0;
  std::vector<std::string> fields, sizes, types, counts;
  long long points = -1;
  int fields_line = 0;
  std::map<std::string, int> key_lines;  // header key -> its line
  while (NextLine(data, &pos, &line)) {
    ++line_no;
    auto w = Words(line);
    if (w.empty() || w[0][0] == '#') continue;
    const std::string key = w[0];
    w.erase(w.begin());
    if (w.size() > static_cast<size_t>(limits::kMaxCloudFields))
      throw InputError(source, line_no, key,
                       std::to_string(w.size()) +
                           " entries, beyond the limit "
                           "of " +
                           std::to_string(limits::kMaxCloudFields) + " fields");
    if (key == "VERSION" || key == "VIEWPOINT") continue;
    // Each line once: which of two POINTS (or FIELDS) lines would count is
    // a guess, and PCL acts on each.
    const auto [seen, first] = key_lines.emplace(key, line_no);
    if (!first)
      throw InputError(
          source, line_no, key,
          "given twice (first on line " + std::to_string(seen->second) + ")");
    if (key == "FIELDS") {
      fields = w;
      fields_line = line_no;
    } else if (key == "SIZE") {
      sizes = w;
    } else if (key == "TYPE") {
      types = w;
    } else if (key == "COUNT") {
      counts = w;
    } else if (key == "WIDTH" && w.size() == 1) {
      h.width =
          HeaderInteger(w[0], source, line_no, key, limits::kMaxCloudPoints);
    } else if (key == "HEIGHT" && w.size() == 1) {
      h.height =
          HeaderInteger(w[0], source, line_no, key, limits::kMaxCloudPoints);
    } else if (key == "POINTS" && w.size() == 1) {
      points =
          HeaderInteger(w[0], source, line_no, key, limits::kMaxCloudPoints);
    } else if (key == "DATA" && w.size() == 1) {
      h.data_kind = w[0];
      break;
    } else {
      throw InputError(source, line_no, key,
                       "unknown or malformed PCD header line");
    }
  }
  h.body = pos;
  if (h.data_kind.empty())
    throw InputError(source, line_no, "DATA", "missing (truncated header?)");
  if (h.data_kind != "ascii" && h.data_kind != "binary" &&
      h.data_kind != "binary_compressed")
    throw InputError(source, line_no, "DATA",
                     "unsupported PCD data '" + h.data_kind +
                         "' (ascii, binary or binary_compressed)");
  if (fields.empty() || sizes.size() != fields.size() ||
      types.size() != fields.size() ||
      (!counts.empty() && counts.size() != fields.size())) {
    throw InputError(source, fields_line, "FIELDS/SIZE/TYPE/COUNT",
                     "missing or of different lengths");
  }
  std::string size_line = "SIZE", type_line = "TYPE", count_line = "COUNT";
  for (size_t i = 0; i < fields.size(); ++i) {
    const long long size =
        HeaderInteger(sizes[i], source, 0, "SIZE of " + fields[i], 8);
    const long long count =
        counts.empty()
            ? 1
            : HeaderInteger(counts[i], source, 0, "COUNT of " + fields[i],
                            limits::kMaxFieldCount);
    const bool size_ok = size == 1 || size == 2 || size == 4 || size == 8;
    const bool type_ok = types[i] == "F" || types[i] == "I" || types[i] == "U";
    if (!size_ok || !type_ok || count < 1 || (types[i] == "F" && size < 4))
      throw InputError(source, 0, "field " + fields[i],
                       "unsupported TYPE/SIZE/COUNT " + types[i] + "/" +
                           sizes[i] + "/" + std::to_string(count));
    size_line += " " + std::to_string(size);
    type_line += " " + types[i];
    count_line += " " + std::to_string(count);
    h.stride += size * count;
    if (h.stride > limits::kMaxRecordBytes)
      throw InputError(source, 0, "SIZE/COUNT",
                       "a point record of more than " +
                           std::to_string(limits::kMaxRecordBytes) +
                           " bytes is beyond the limit");
  }
  if (points < 0) points = h.width * h.height;
  if (h.width * h.height != points)
    throw InputError(source, 0, "POINTS",
                     std::to_string(points) + " points but WIDTH x HEIGHT = " +
                         std::to_string(h.width * h.height));
  if (points > limits::kMaxCloudPoints)
    throw InputError(source, 0, "POINTS",
                     std::to_string(points) + " points, beyond the limit of " +
                         std::to_string(limits::kMaxCloudPoints));
  if (points <= 0)
    throw InputError(source, 0, "POINTS", "the cloud has no points");
  h.points = points;
  h.for_pcl = "VERSION 0.7\nFIELDS";
  for (const auto& f : fields) h.for_pcl += " " + f;
  h.for_pcl += "\n" + size_line + "\n" + type_line + "\n" + count_line +
               "\nWIDTH " + std::to_string(h.width) + "\nHEIGHT " +
               std::to_string(h.height) + "\nPOINTS " + std::to_string(points) +
               "\nDATA " + h.data_kind + "\n";
  const size_t have = data.size() - std::min(h.body, data.size());
  // PCL sizes its buffer from the header: the data must be there first.
  // Ascii needs two bytes a value at least; LZF expands at most about
  // 100 times.
  const long long values = h.stride == 0 ? 0 : points * h.stride;
  if (values > limits::kMaxCloudBytes)
    throw InputError(source, 0, "POINTS",
                     std::to_string(points) + " points of " +
                         std::to_string(h.stride) +
                         " bytes are beyond the "
                         "limit of " +
                         std::to_string(limits::kMaxCloudBytes) + " bytes");
  if (h.data_kind == "ascii" &&
      static_cast<long long>(have) <
          2 * points * static_cast<long long>(fields.size()))
    throw InputError(source, 0, "POINTS",
                     "truncated: header declares " + std::to_string(points) +
                         " points, the file is too short to hold them");
  if (h.data_kind == "binary" &&
      have < static_cast<size_t>(h.stride) * static_cast<size_t>(points)) {
    throw InputError(source, 0, "point " + std::to_string(have / h.stride),
                     "truncated: header declares " + std::to_string(points) +
                         " points, data holds " +
                         std::to_string(have / h.stride));
  }
  if (h.data_kind == "binary_compressed") {
    uint32_t sizes_of[2] = {0, 0};  // compressed, uncompressed
    if (have < 8)
      throw InputError(source, 0, "DATA", "compressed data truncated");
    std::memcpy(sizes_of, data.data() + h.body, 8);
    if (sizes_of[0] > have - 8)
      throw InputError(
          source, 0, "DATA",
          "compressed data truncated: " + std::to_string(sizes_of[0]) +
              " bytes declared, " + std::to_string(have - 8) + " present");
    if (static_cast<long long>(sizes_of[1]) > 100LL * sizes_of[0] + 1024)
      throw InputError(source, 0, "DATA",
                       "compressed data of " + std::to_string(sizes_of[0]) +
                           " bytes cannot hold " + std::to_string(points) +
                           " points");
    if (static_cast<long long>(sizes_of[1]) != h.stride * points)
      throw InputError(source, 0, "DATA",
                       "uncompressed size " + std::to_string(sizes_of[1]) +
                           " does not match the header (" +
                           std::to_string(h.stride * points) + " bytes)");
  }
  return h;
}

double FieldValue(const uint8_t* p, uint8_t datatype) {
  auto get = [p](auto v) {
    std::memcpy(&v, p, sizeof v);
    return static_cast<double>(v);
  };
  switch (datatype) {
    case pcl::PCLPointField::FLOAT64:
      return get(double{});
    case pcl::PCLPointField::FLOAT32:
      return get(float{});
    case pcl::PCLPointField::INT8:
      return get(int8_t{});
    case pcl::PCLPointField::UINT8:
      return get(uint8_t{});
    case pcl::PCLPointField::INT16:
      return get(int16_t{});
    case pcl::PCLPointField::UINT16:
      return get(uint16_t{});
    case pcl::PCLPointField::INT32:
      return get(int32_t{});
    case pcl::PCLPointField::UINT32:
      return get(uint32_t{});
    case pcl::PCLPointField::INT64:
      return get(int64_t{});
    case pcl::PCLPointField::UINT64:
      return get(uint64_t{});
    default:
      return std::numeric_limits<double>::quiet_NaN();
  }
}

PointCloud ReadPcd(std::string_view data, const std::string& source,
                   double scale) {
  const PcdHeader h = CheckPcdHeader(data, source);
  pcl::PCLPointCloud2 pc;
  {
    const QuietPcl quiet;
    pcl::PCDReader reader;
    Eigen::Vector4f origin;
    Eigen::Quaternionf orientation;
    int version = 0, data_type = 0;
    unsigned int data_idx = 0;
    MemoryBuffer header_buffer(h.for_pcl.data(),
                               h.for_pcl.data() + h.for_pcl.size());
    std::istream header_stream(&header_buffer);
    // PCL's header reader throws on what it cannot take (std::vector::at,
    // its own messages); the header it is given was checked, so a throw
    // here would be a rule of PCL's not known to the check.
    int header_rc = -1;
    try {
      header_rc = reader.readHeader(header_stream, pc, origin, orientation,
                                    version, data_type, data_idx);
    } catch (const std::exception& e) {
      throw InputError(
          source, 0, "header",
          std::string("PCL cannot read the PCD header (") + e.what() + ")");
    }
    if (header_rc != 0)
      throw InputError(source, 0, "header", "PCL cannot read the PCD header");
    int rc = 0;
    if (data_type == 0) {
      MemoryBuffer body(data.data() + h.body, data.data() + data.size());
      std::istream body_stream(&body);
      rc = reader.readBodyASCII(body_stream, pc, version);
    } else {
      rc = reader.readBodyBinary(
          reinterpret_cast<const unsigned char*>(data.data()), pc, version,
          data_type == 2, static_cast<unsigned int>(h.body));
    }
    if (rc != 0)
      throw InputError(source, 0, "DATA",
                       "PCL cannot read the point data (truncated or "
                       "malformed " +
                           h.data_kind + " body)");
  }
  const auto field = [&](const char* name) -> const pcl::PCLPointField* {
    for (const auto& f : pc.fields)
      if (f.name == name) return &f;
    return nullptr;
  };
  const pcl::PCLPointField* fx[3] = {field("x"), field("y"), field("z")};
  const pcl::PCLPointField* fn[3] = {field("normal_x"), field("normal_y"),
                                     field("normal_z")};
  for (int a = 0; a < 3; ++a)
    if (fx[a] == nullptr)
      throw InputError(source, 0, "FIELDS",
                       std::string("no field ") + "xyz"[a]);
  const bool normals = fn[0] && fn[1] && fn[2];
  const size_t n = static_cast<size_t>(pc.width) * pc.height;
  if (pc.data.size() < n * pc.point_step || n != static_cast<size_t>(h.points))
    throw InputError(source, 0, "DATA", "point data shorter than declared");
  PointCloud cloud;
  cloud.source = source;
  Eigen::Matrix3Xd xyz_m(3, static_cast<Eigen::Index>(n));
  std::vector<double> nrm;
  if (normals) nrm.reserve(3 * n);
  size_t kept = 0, empty = 0;
  for (size_t i = 0; i < n; ++i) {
    const uint8_t* rec = pc.data.data() + i * pc.point_step;
    double p[3], q[3] = {0, 0, 0};
    for (int a = 0; a < 3; ++a) {
      p[a] = FieldValue(rec + fx[a]->offset, fx[a]->datatype);
      if (normals) q[a] = FieldValue(rec + fn[a]->offset, fn[a]->datatype);
    }
    // PCL marks a point without a return (organised clouds) with NaN.
    if (std::isnan(p[0]) && std::isnan(p[1]) && std::isnan(p[2])) {
      ++empty;
      continue;
    }
    const std::string where =
        pc.height > 1 ? "point " + std::to_string(i) + " (row " +
                            std::to_string(i / pc.width) + ", column " +
                            std::to_string(i % pc.width) + ")"
                      : "point " + std::to_string(i);
    for (int a = 0; a < 3; ++a) {
      if (!std::isfinite(p[a]))
        throw InputError(source, 0, where,
                         "coordinate is not a finite number (NaN or inf)");
      if (std::abs(p[a]) > limits::kMaxCoordinateMm / scale)
        throw InputError(source, 0, where,
                         "coordinate " + std::to_string(p[a]) +
                             " is beyond the limit of " +
                             std::to_string(limits::kMaxCoordinateMm) + " mm");
      xyz_m(a, static_cast<Eigen::Index>(kept)) = p[a];
    }
    if (normals) nrm.insert(nrm.end(), q, q + 3);
    ++kept;
  }
  if (empty > 0)
    cloud.warnings.push_back(std::to_string(empty) + " of " +
                             std::to_string(n) +
                             " points are NaN (no return) and were skipped");
  xyz_m.conservativeResize(3, static_cast<Eigen::Index>(kept));
  FinishCloud(&cloud, std::move(xyz_m), nrm, scale);
  return cloud;
}

std::string Num(double v) {
  char buf[40];
  auto [p, ec] = std::to_chars(buf, buf + sizeof buf, v);  // shortest exact
  return std::string(buf, p);
}

}  // namespace

double MillimetresPer(LengthUnit unit) {
  switch (unit) {
    case LengthUnit::kMetre:
      return 1000.0;
    case LengthUnit::kInch:
      return 25.4;
    default:
      return 1.0;
  }
}

LengthUnit ParseLengthUnit(const std::string& text) {
  if (text == "mm") return LengthUnit::kMillimetre;
  if (text == "m") return LengthUnit::kMetre;
  if (text == "in") return LengthUnit::kInch;
  throw InputError("--units", 0, "units", "'" + text + "' is not mm, m or in");
}

void AdviseHugePages(void* data, size_t bytes) {
  constexpr uintptr_t kHuge = uintptr_t{2} << 20;
  if (bytes < 4 * kHuge) return;
  const uintptr_t begin =
      (reinterpret_cast<uintptr_t>(data) + kHuge - 1) & ~(kHuge - 1);
  const uintptr_t end =
      (reinterpret_cast<uintptr_t>(data) + bytes) & ~(kHuge - 1);
  if (end > begin)
    ::madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
}

const char* CloudFormatName(CloudFormat f) {
  switch (f) {
    case CloudFormat::kPcdAscii:
      return "pcd-ascii";
    case CloudFormat::kPcdBinary:
      return "pcd-binary";
    case CloudFormat::kPlyAscii:
      return "ply-ascii";
    case CloudFormat::kPlyBinary:
      return "ply-binary";
    case CloudFormat::kXyz:
      return "xyz";
    case CloudFormat::kCsv:
      return "csv";
  }
  return "?";
}

const char* CloudFormatExtension(CloudFormat f) {
  switch (f) {
    case CloudFormat::kPcdAscii:
    case CloudFormat::kPcdBinary:
      return ".pcd";
    case CloudFormat::kPlyAscii:
    case CloudFormat::kPlyBinary:
      return ".ply";
    case CloudFormat::kXyz:
      return ".xyz";
    case CloudFormat::kCsv:
      return ".csv";
  }
  return "";
}

PointCloud ReadPointCloud(const std::filesystem::path& path,
                          const ReadOptions& options) {
  if (!IsRegularInput(path))  // a pipe: its bytes, read once
    return ParsePointCloud(ReadTextFile(path), path.string(), options);
  const MappedFile file(path);
  NoteInput(path);  // never written over by this command's outputs
  return ParsePointCloud(file.view(), path.string(), options);
}

namespace {

// A point given twice with the same coordinates (a double hit, or a cloud
// written twice) is one measurement: counted twice it would shrink every
// uncertainty by sqrt(2) and weigh its place twice. Exact repeats are
// dropped, the first kept, the order otherwise unchanged.
void DropRepeatedPoints(PointCloud* cloud) {
  const Eigen::Index n = cloud->size();
  if (n < 2) return;
  const auto bits = [&](Eigen::Index i, int a) {
    // +0 and -0 are one coordinate.
    const double v = cloud->xyz_mm(a, i) + 0.0;
    uint64_t u;
    std::memcpy(&u, &v, sizeof u);
    return u;
  };
  // One pass over an open-addressing table of the distinct points seen so
  // far (linear probing, at most half full): a point whose coordinates are
  // in it repeats an earlier one. A slot holds the hash's high 32 bits and
  // 1 + the index of the first point with these coordinates (0: empty), so
  // a million points take 16 MB. (Sorting the hashes instead took a tenth
  // of a million-point inspection.)
  static_assert(limits::kMaxCloudPoints < (std::int64_t{1} << 32) - 1);
  size_t slots = 2;
  while (slots < 2 * static_cast<size_t>(n)) slots *= 2;
  const size_t mask = slots - 1;
  std::vector<uint64_t> table(slots, 0);
  std::vector<char> repeat(static_cast<size_t>(n), 0);
  size_t repeats = 0;
  const auto hash = [&](Eigen::Index i) {
    uint64_t h = 1469598103934665603ull;
    for (int a = 0; a < 3; ++a) h = (h ^ bits(i, a)) * 1099511628211ull;
    // The product's low bits depend only on the coordinates' low mantissa
    // bits (all zero for round numbers): MurmurHash3's finaliser mixes the
    // high ones in before the table's mask keeps the low ones.
    h ^= h >> 33;
    h *= 0xff51afd7ed558ccdull;
    h ^= h >> 33;
    h *= 0xc4ceb9fe1a85ec53ull;
    h ^= h >> 33;
    return h;
  };
  // Each look-up is a cache miss in a table far larger than the cache: the
  // slot of the point kAhead on is fetched while this one is looked up
  // (its hash waits in a ring).
  constexpr Eigen::Index kAhead = 16;
  uint64_t ahead[kAhead];
  for (Eigen::Index i = 0; i < std::min(kAhead, n); ++i) ahead[i] = hash(i);
  for (Eigen::Index i = 0; i < n; ++i) {
    const uint64_t h = ahead[i % kAhead];
    if (i + kAhead < n) {
      const uint64_t next = hash(i + kAhead);
      ahead[i % kAhead] = next;
      __builtin_prefetch(&table[next & mask]);
    }
    const uint64_t tag = h & 0xffffffff00000000ull;
    for (size_t s = h & mask;; s = (s + 1) & mask) {
      const uint64_t slot = table[s];
      if (slot == 0) {
        table[s] = tag | static_cast<uint64_t>(i + 1);
        break;
      }
      const auto first = static_cast<Eigen::Index>(slot & 0xffffffffull) - 1;
      if ((slot & 0xffffffff00000000ull) == tag &&
          cloud->xyz_mm.col(first) == cloud->xyz_mm.col(i)) {
        repeat[static_cast<size_t>(i)] = 1;
        ++repeats;
        break;
      }
    }
  }
  if (repeats == 0) return;
  Eigen::Index kept = 0;
  for (Eigen::Index i = 0; i < n; ++i) {
    if (repeat[static_cast<size_t>(i)]) continue;
    cloud->xyz_mm.col(kept) = cloud->xyz_mm.col(i);
    if (cloud->has_normals) cloud->normals.col(kept) = cloud->normals.col(i);
    ++kept;
  }
  cloud->xyz_mm.conservativeResize(3, kept);
  if (cloud->has_normals) cloud->normals.conservativeResize(3, kept);
  cloud->warnings.push_back(fmt::format(
      "{} of {} points repeat another point exactly (double hits) and were "
      "dropped: a repeated point is one measurement",
      repeats, n));
}

PointCloud ParseAnyPointCloud(std::string_view data, const std::string& source,
                              const ReadOptions& options);

}  // namespace

PointCloud ParsePointCloud(std::string_view data, const std::string& source,
                           const ReadOptions& options) {
  // A text cloud from a program that writes a UTF-8 byte order mark first.
  if (data.substr(0, 3) == "\xEF\xBB\xBF") data.remove_prefix(3);
  PointCloud cloud = ParseAnyPointCloud(data, source, options);
  DropRepeatedPoints(&cloud);
  return cloud;
}

namespace {

PointCloud ParseAnyPointCloud(std::string_view data, const std::string& source,
                              const ReadOptions& options) {
  const double scale = MillimetresPer(options.units);
  const std::string ext =
      Lower(std::filesystem::path(source).extension().string());
  if (data.empty()) throw InputError(source, 0, "", "the file is empty");
  // Content first: a header says what the file is whatever its name.
  if (data.compare(0, 3, "ply") == 0 &&
      (data.size() == 3 || std::isspace(static_cast<unsigned char>(data[3])))) {
    return ReadPly(data, source, scale);
  }
  const size_t first = data.find_first_not_of(" \t\r\n");
  if (first == std::string_view::npos)
    throw InputError(source, 0, "", "the file holds only blank space");
  const std::string head(data.substr(first, 64));
  if (head.rfind("# .PCD", 0) == 0 || head.rfind("VERSION", 0) == 0 ||
      head.rfind("FIELDS", 0) == 0) {
    return ReadPcd(data, source, scale);
  }
  if (ext == ".ply" || ext == ".pcd") {
    throw InputError(source, 1, "header",
                     "wrong header for a " + ext + " file (expected " +
                         (ext == ".ply" ? "'ply'" : "a PCD header") + ")");
  }
  if (ext == ".xyz" || ext == ".txt" || ext == ".csv" || ext == ".asc" ||
      ext == ".pts") {
    return ReadText(data, source, scale);
  }
  // Unknown extension: text only if it looks like numbers.
  if (std::isdigit(static_cast<unsigned char>(head[0])) || head[0] == '-' ||
      head[0] == '+' || head[0] == '#') {
    return ReadText(data, source, scale);
  }
  throw InputError(
      source, 0, "",
      "unknown point cloud format (PCD, PLY or .xyz/.txt/.csv text)");
}

}  // namespace

void WritePointCloud(const std::filesystem::path& path, const PointCloud& cloud,
                     CloudFormat format) {
  const Eigen::Index n = cloud.size();
  const bool nrm = cloud.has_normals;
  std::string out;
  auto ascii_rows = [&](char sep) {
    std::string line;
    for (Eigen::Index i = 0; i < n; ++i) {
      line.clear();
      for (int a = 0; a < 3; ++a) {
        if (a) line += sep;
        line += Num(cloud.xyz_mm(a, i));
      }
      if (nrm) {
        for (int a = 0; a < 3; ++a) line += sep + Num(cloud.normals(a, i));
      }
      out += line;
      out += '\n';
    }
  };
  auto binary_rows = [&]() {
    const size_t rec = nrm ? 48 : 24;
    const size_t start = out.size();
    out.resize(start + rec * n);
    char* p = out.data() + start;
    for (Eigen::Index i = 0; i < n; ++i, p += rec) {
      std::memcpy(p, cloud.xyz_mm.col(i).data(), 24);
      if (nrm) std::memcpy(p + 24, cloud.normals.col(i).data(), 24);
    }
  };
  switch (format) {
    case CloudFormat::kXyz:
      out = "# x y z" + std::string(nrm ? " nx ny nz" : "") + " (mm)\n";
      ascii_rows(' ');
      break;
    case CloudFormat::kCsv:
      out = std::string("x,y,z") + (nrm ? ",nx,ny,nz" : "") + "\n";
      ascii_rows(',');
      break;
    case CloudFormat::kPlyAscii:
    case CloudFormat::kPlyBinary: {
      const bool bin = format == CloudFormat::kPlyBinary;
      const char* t = "double";  // coordinates are kept in double
      out = "ply\nformat " +
            std::string(bin ? "binary_little_endian" : "ascii") +
            " 1.0\ncomment ttp point cloud, mm\nelement vertex " +
            std::to_string(n) + "\n";
      for (const char* a : {"x", "y", "z"})
        out += std::string("property ") + t + " " + a + "\n";
      if (nrm) {
        for (const char* a : {"nx", "ny", "nz"})
          out += std::string("property ") + t + " " + a + "\n";
      }
      out += "end_header\n";
      if (bin)
        binary_rows();
      else
        ascii_rows(' ');
      break;
    }
    case CloudFormat::kPcdAscii:
    case CloudFormat::kPcdBinary: {
      const bool bin = format == CloudFormat::kPcdBinary;
      out = "# .PCD v0.7 - ttp point cloud, mm\nVERSION 0.7\nFIELDS x y z";
      out += nrm ? " normal_x normal_y normal_z\nSIZE 8 8 8 8 8 8\nTYPE F F F "
                   "F F F\nCOUNT 1 1 1 1 1 1\n"
                 : "\nSIZE 8 8 8\nTYPE F F F\nCOUNT 1 1 1\n";
      out += "WIDTH " + std::to_string(n) +
             "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " +
             std::to_string(n) + "\nDATA " + (bin ? "binary" : "ascii") + "\n";
      if (bin)
        binary_rows();
      else
        ascii_rows(' ');
      break;
    }
  }
  WriteFileAtomic(path, out);
}

}  // namespace ttp::inspect
