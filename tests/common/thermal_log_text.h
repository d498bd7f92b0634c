// Thermal logs (thermal-log.md CSV) edited as text for end-to-end tests:
// the real log with a fault put in where the test says.
#pragma once

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace ttp::test {

// The cells of one CSV row (no quoting in thermal logs).
inline std::vector<std::string> CsvCells(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream ss(line);
  std::string cell;
  while (std::getline(ss, cell, ',')) cells.push_back(cell);
  return cells;
}

// A copy of `in` with `step` added to `column` in every data row whose t_s
// is at or after `from_t_s` (a sensor that jumps there and stays shifted).
// Returns the path written; fails the test when the column is not there.
inline std::string WriteWithStep(const std::filesystem::path& in,
                                 const std::filesystem::path& out,
                                 const std::string& column, double from_t_s,
                                 double step) {
  std::ifstream src(in);
  std::ofstream dst(out);
  std::string line;
  int at = -1;
  bool header = true;
  while (std::getline(src, line)) {
    if (line.empty() || line[0] == '#') {
      dst << line << "\n";
      continue;
    }
    std::vector<std::string> cells = CsvCells(line);
    if (header) {
      header = false;
      for (size_t k = 0; k < cells.size(); ++k)
        if (cells[k] == column) at = static_cast<int>(k);
      EXPECT_GE(at, 0) << column << " is not a column of " << in;
    } else if (at >= 0 && std::stod(cells[0]) >= from_t_s) {
      cells[at] = fmt::format("{:.4f}", std::stod(cells[at]) + step);
    }
    for (size_t k = 0; k < cells.size(); ++k) dst << (k ? "," : "") << cells[k];
    dst << "\n";
  }
  return out.string();
}

}  // namespace ttp::test
