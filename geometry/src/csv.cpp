#include "ttp/geometry/csv.h"

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include "ttp/geometry/error.h"

namespace ttp {

std::string Trim(const std::string& s) {
  const size_t b = s.find_first_not_of(" \t\r");
  if (b == std::string::npos) return "";
  const size_t e = s.find_last_not_of(" \t\r");
  return s.substr(b, e - b + 1);
}

std::string Upper(std::string s) {
  for (char& c : s)
    c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

std::string Lower(std::string s) {
  for (char& c : s)
    c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

namespace {

std::vector<std::string> SplitCells(const std::string& line) {
  std::vector<std::string> cells;
  std::string cell;
  std::istringstream in(line);
  while (std::getline(in, cell, ',')) cells.push_back(Trim(cell));
  if (!line.empty() && line.back() == ',') cells.push_back("");
  return cells;
}

}  // namespace

std::string SeparatorHint(const std::vector<std::string>& header_cells) {
  if (header_cells.size() != 1) return "";
  const std::string& only = header_cells.front();
  for (const char* separator : {";", "\t", "|"}) {
    if (only.find(separator[0]) == std::string::npos) continue;
    const std::string shown = separator[0] == '\t'
                                  ? std::string("a tab")
                                  : "'" + std::string(separator) + "'";
    return ": the header holds no comma but " + shown +
           " (a file separated by " + shown +
           "); the format is comma separated";
  }
  return "";
}

int CsvTable::Require(const std::string& column) const {
  auto it = index.find(column);
  if (it == index.end()) {
    throw InputError(
        source, header_line, column,
        "required column is missing from the header" + SeparatorHint(columns));
  }
  return it->second;
}

const std::string& CsvTable::Text(const CsvRow& row, int column) const {
  return row.cells.at(static_cast<size_t>(column));
}

double CsvTable::Number(const CsvRow& row, int column) const {
  const std::string& cell = Text(row, column);
  const std::string& name = columns.at(static_cast<size_t>(column));
  if (cell.empty()) throw InputError(source, row.line, name, "empty cell");
  return ParseFiniteNumber(cell, source, row.line, name);
}

double ParseFiniteNumber(const std::string& cell, const std::string& source,
                         int line, const std::string& column) {
  const char* begin = cell.c_str();
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(begin, &end);
  if (end == begin || *end != '\0')
    throw InputError(source, line, column, "'" + cell + "' is not a number");
  // ERANGE on underflow (1e-320, a subnormal or a flush to 0) still gives
  // a finite number near zero: only an overflow is not finite.
  if (!std::isfinite(v) || (errno == ERANGE && std::abs(v) > 1.0))
    throw InputError(source, line, column,
                     "'" + cell + "' is not a finite number");
  return v;
}

CsvTable ParseCsv(const std::string& text, const std::string& source) {
  CsvTable table;
  table.source = source;
  std::istringstream in(text);
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (number == 1 && line.rfind("\xEF\xBB\xBF", 0) == 0) line.erase(0, 3);
    const std::string trimmed = Trim(line);
    if (trimmed.empty() || trimmed[0] == '#') continue;
    std::vector<std::string> cells = SplitCells(trimmed);
    if (table.columns.empty()) {
      table.columns = cells;
      table.header_line = number;
      for (size_t i = 0; i < cells.size(); ++i) {
        if (cells[i].empty()) {
          throw InputError(source, number, "header",
                           "column " + std::to_string(i + 1) + " has no name");
        }
        if (!table.index.emplace(cells[i], static_cast<int>(i)).second) {
          throw InputError(source, number, cells[i], "duplicate column");
        }
      }
      continue;
    }
    if (cells.size() != table.columns.size()) {
      throw InputError(source, number, "",
                       "row has " + std::to_string(cells.size()) +
                           " cells, the header has " +
                           std::to_string(table.columns.size()));
    }
    table.rows.push_back({number, std::move(cells)});
  }
  if (table.columns.empty()) {
    throw InputError(source, 0, "", "empty file: no header row");
  }
  return table;
}

}  // namespace ttp
