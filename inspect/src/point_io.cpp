#include "ttp/inspect/point_io.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string_view>

#include "ttp/geometry/csv.h"
#include "ttp/geometry/error.h"
#include "ttp/geometry/file_io.h"

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
      try {
        e.count = std::stoll(w[2]);
      } catch (...) {
        throw InputError(source, line_no, "element",
                         "count '" + w[2] + "' is not a number");
      }
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
  }
  FinishCloud(&cloud, std::move(xyz_m), nrm, scale);
  return cloud;
}

// ---------------------------------------------------------------- PCD
PointCloud ReadPcd(std::string_view data, const std::string& source,
                   double scale) {
  PointCloud cloud;
  cloud.source = source;
  size_t pos = 0;
  std::string line;
  int line_no = 0;
  std::vector<std::string> fields, sizes, types, counts;
  long long points = -1, width = -1, height = 1;
  std::string data_kind;
  while (NextLine(data, &pos, &line)) {
    ++line_no;
    auto w = Words(line);
    if (w.empty() || w[0][0] == '#') continue;
    const std::string key = w[0];
    w.erase(w.begin());
    if (key == "VERSION" || key == "VIEWPOINT") continue;
    if (key == "FIELDS")
      fields = w;
    else if (key == "SIZE")
      sizes = w;
    else if (key == "TYPE")
      types = w;
    else if (key == "COUNT")
      counts = w;
    else if (key == "WIDTH" && w.size() == 1)
      width = std::atoll(w[0].c_str());
    else if (key == "HEIGHT" && w.size() == 1)
      height = std::atoll(w[0].c_str());
    else if (key == "POINTS" && w.size() == 1)
      points = std::atoll(w[0].c_str());
    else if (key == "DATA" && w.size() == 1) {
      data_kind = w[0];
      break;
    } else {
      throw InputError(source, line_no, key,
                       "unknown or malformed PCD header line");
    }
  }
  if (data_kind.empty())
    throw InputError(source, line_no, "DATA", "missing (truncated header?)");
  if (fields.empty() || sizes.size() != fields.size() ||
      types.size() != fields.size()) {
    throw InputError(source, 0, "FIELDS/SIZE/TYPE",
                     "missing or of different lengths");
  }
  if (counts.empty()) counts.assign(fields.size(), "1");
  if (points < 0) points = width * height;
  std::vector<Property> props;
  int stride = 0;
  for (size_t i = 0; i < fields.size(); ++i) {
    const int size = std::atoi(sizes[i].c_str());
    const int count = std::atoi(counts[i].c_str());
    std::string t;
    if (types[i] == "F")
      t = size == 8 ? "double" : size == 4 ? "float" : "";
    else if (types[i] == "I")
      t = size == 1 ? "int8" : size == 2 ? "int16" : size == 4 ? "int32" : "";
    else if (types[i] == "U")
      t = size == 1   ? "uint8"
          : size == 2 ? "uint16"
          : size == 4 ? "uint32"
                      : "";
    if (t.empty() || count < 1) {
      throw InputError(source, 0, "field " + fields[i],
                       "unsupported TYPE/SIZE/COUNT");
    }
    for (int c = 0; c < count; ++c) {
      props.push_back({c == 0 ? fields[i] : fields[i] + "_" + std::to_string(c),
                       t, stride});
      stride += size;
    }
  }
  int ix[3], in[3];
  FindXyz(props, ix, in, "normal_x", "normal_y", "normal_z");
  for (int a = 0; a < 3; ++a) {
    if (ix[a] < 0)
      throw InputError(source, 0, "FIELDS",
                       std::string("no field ") + "xyz"[a]);
  }
  const bool normals = in[0] >= 0 && in[1] >= 0 && in[2] >= 0;
  if (points <= 0)
    throw InputError(source, 0, "POINTS", "the cloud has no points");
  Eigen::Matrix3Xd xyz_m(3, points);
  AdviseHugePages(xyz_m.data(), sizeof(double) * 3 * points);
  double* xyz = xyz_m.data();
  std::vector<double> nrm(normals ? 3 * points : 0);
  if (data_kind == "binary") {
    if (data.size() < pos + static_cast<size_t>(stride) * points) {
      const long long have =
          (data.size() - std::min(pos, data.size())) / stride;
      throw InputError(source, 0, "point " + std::to_string(have),
                       "truncated: header declares " + std::to_string(points) +
                           " points, data holds " + std::to_string(have));
    }
    for (long long i = 0; i < points; ++i) {
      const char* rec = data.data() + pos + i * stride;
      for (int a = 0; a < 3; ++a) {
        xyz[3 * i + a] =
            ReadScalar(rec + props[ix[a]].offset, props[ix[a]].type);
        if (normals)
          nrm[3 * i + a] =
              ReadScalar(rec + props[in[a]].offset, props[in[a]].type);
      }
      if (!std::isfinite(xyz[3 * i]) || !std::isfinite(xyz[3 * i + 1]) ||
          !std::isfinite(xyz[3 * i + 2])) {
        throw InputError(source, 0, "point " + std::to_string(i),
                         "coordinate is not a finite number (NaN or inf)");
      }
    }
  } else if (data_kind == "ascii") {
    std::vector<double> nums;
    std::string bad;
    for (long long i = 0; i < points; ++i) {
      if (!NextLine(data, &pos, &line)) {
        throw InputError(source, line_no + 1, "point " + std::to_string(i),
                         "truncated: header declares " +
                             std::to_string(points) + " points, file holds " +
                             std::to_string(i));
      }
      ++line_no;
      if (!ParseNumbers(line.data(), line.data() + line.size(), &nums, &bad) ||
          nums.size() != props.size()) {
        throw InputError(
            source, line_no, "point " + std::to_string(i),
            "expected " + std::to_string(props.size()) + " numbers");
      }
      for (int a = 0; a < 3; ++a) {
        xyz[3 * i + a] = nums[ix[a]];
        if (normals) nrm[3 * i + a] = nums[in[a]];
      }
      CheckFinite(source, line_no, "point " + std::to_string(i), &xyz[3 * i],
                  3);
    }
  } else {
    throw InputError(
        source, 0, "DATA",
        "unsupported PCD data '" + data_kind + "' (ascii or binary)");
  }
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
  const std::string source = path.string();
  const MappedFile file(path);
  const std::string_view data = file.view();
  const double scale = MillimetresPer(options.units);
  const std::string ext = Lower(path.extension().string());
  if (data.empty()) throw InputError(source, 0, "", "the file is empty");
  // Content first: a header says what the file is whatever its name.
  if (data.compare(0, 3, "ply") == 0 &&
      (data.size() == 3 || std::isspace(static_cast<unsigned char>(data[3])))) {
    return ReadPly(data, source, scale);
  }
  const size_t first = data.find_first_not_of(" \t\r\n");
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
