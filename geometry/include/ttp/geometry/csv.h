// Small CSV reader shared by the toolkit's CSV inputs (R-test spheres,
// probe results, dial readings): comma separated, `#` comment lines, a
// header row naming the columns, line numbers kept for error messages.
#pragma once

#include <map>
#include <string>
#include <vector>

namespace ttp {

struct CsvRow {
  int line = 0;  // 1-based line in the file
  std::vector<std::string> cells;
};

struct CsvTable {
  std::string source;
  int header_line = 0;
  std::vector<std::string> columns;
  std::map<std::string, int> index;  // column name -> position
  std::vector<CsvRow> rows;

  // Column position; throws InputError naming the missing column.
  int Require(const std::string& column) const;
  bool Has(const std::string& column) const { return index.count(column); }
  // The cell as a finite number; throws InputError(source, line, column).
  double Number(const CsvRow& row, int column) const;
  const std::string& Text(const CsvRow& row, int column) const;
};

// Without leading and trailing spaces, tabs and carriage returns.
std::string Trim(const std::string& s);
// ASCII case conversion of every character.
std::string Upper(std::string s);
std::string Lower(std::string s);

// What to add to a "missing column" error when the header row was read as
// one cell holding another separator (';', a tab or '|'): ": the header
// holds no comma but ';' (a file separated by ';'); the format is comma
// separated"; "" for any other header.
std::string SeparatorHint(const std::vector<std::string>& header_cells);

// A cell as a finite number; throws InputError(source, line, column) when it
// is not a number ("'x' is not a number") or not finite, or overflows.
double ParseFiniteNumber(const std::string& cell, const std::string& source,
                         int line, const std::string& column);

// Parses CSV text. Rows with a different cell count than the header are an
// error naming the line. Leading/trailing spaces of cells are trimmed.
CsvTable ParseCsv(const std::string& text, const std::string& source);

}  // namespace ttp
