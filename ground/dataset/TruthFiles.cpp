#include "ground/dataset/TruthFiles.hpp"

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "ground/dataset/DatasetFile.hpp"

namespace areomap {
namespace {

constexpr std::size_t kMaxCsvLineBytes = 1 << 20;  // a sane bound: CSV lines here are < 200 bytes

std::string trim(const std::string& s) {
  std::size_t b = 0, e = s.size();
  while (b < e && (s[b] == ' ' || s[b] == '\t' || s[b] == '\r')) ++b;
  while (e > b && (s[e - 1] == ' ' || s[e - 1] == '\t' || s[e - 1] == '\r')) --e;
  return s.substr(b, e - b);
}

std::vector<std::string> splitCsv(const std::string& line) {
  std::vector<std::string> cells;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    cells.push_back(trim(line.substr(start, comma == std::string::npos ? std::string::npos : comma - start)));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return cells;
}

// A CSV table read by column names, with errors that name file, line and column.
class CsvTable {
 public:
  CsvTable(const std::string& path, const std::vector<std::string>& required, const std::vector<std::string>& optional)
      : path_(path), in_(path, std::ios::binary) {
    if (!in_) throw DatasetError(path_, "", std::string("cannot open: ") + std::strerror(errno));
    std::vector<std::string> header;
    if (!nextRow(header)) throw DatasetError(path_, "line 1", "empty file: expected a header line");
    header_line_ = line_number_;
    for (std::size_t i = 0; i < header.size(); ++i) columns_[header[i]] = i;
    for (const std::string& name : required) {
      if (columns_.count(name) == 0) {
        throw DatasetError(path_, "line " + std::to_string(header_line_),
                           "header lacks the column '" + name + "' (expected " + expected(required, optional) + ")");
      }
    }
  }

  bool has(const std::string& column) const { return columns_.count(column) != 0; }

  // Reads the next data row; false at the end of the file.
  bool next() { return nextRow(row_); }

  const std::string& cell(const std::string& column) const {
    const std::size_t index = columns_.at(column);
    if (index >= row_.size()) fail(column, "missing value (the row has " + std::to_string(row_.size()) + " columns)");
    return row_[index];
  }

  double number(const std::string& column) const {
    const std::string& text = cell(column);
    double value = 0.0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (text.empty() || ec != std::errc() || end != text.data() + text.size() || !std::isfinite(value)) {
      fail(column, "expected a finite number, got '" + text + "'");
    }
    return value;
  }

  int64_t integer(const std::string& column) const {
    const std::string& text = cell(column);
    int64_t value = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
    if (text.empty() || ec != std::errc() || end != text.data() + text.size()) {
      fail(column, "expected an integer, got '" + text + "'");
    }
    return value;
  }

  [[noreturn]] void fail(const std::string& column, const std::string& message) const {
    const std::size_t index = columns_.count(column) != 0 ? columns_.at(column) : 0;
    throw DatasetError(path_, "line " + std::to_string(line_number_) + ", column " + std::to_string(index + 1) + " (" + column + ")",
                       message);
  }

 private:
  static std::string expected(const std::vector<std::string>& required, const std::vector<std::string>& optional) {
    std::string s;
    for (const std::string& c : required) s += (s.empty() ? "" : ",") + c;
    for (const std::string& c : optional) s += "[," + c + "]";
    return s;
  }

  bool nextRow(std::vector<std::string>& row) {
    std::string line;
    while (std::getline(in_, line)) {
      ++line_number_;
      if (line.size() > kMaxCsvLineBytes) throw DatasetError(path_, "line " + std::to_string(line_number_), "line too long");
      const std::string t = trim(line);
      if (t.empty() || t[0] == '#') continue;
      row = splitCsv(t);
      return true;
    }
    if (in_.bad()) throw DatasetError(path_, "", "read error");
    return false;
  }

  std::string path_;
  std::ifstream in_;
  std::map<std::string, std::size_t> columns_;
  std::vector<std::string> row_;
  int64_t line_number_ = 0;
  int64_t header_line_ = 0;
};

}  // namespace

std::string formatDouble(double value) {
  char buffer[64];
  const auto [end, ec] = std::to_chars(buffer, buffer + sizeof(buffer), value);
  if (ec != std::errc()) return "nan";
  return std::string(buffer, end);
}

std::vector<CheckPoint> readPointsCsv(const std::string& path) {
  CsvTable table(path, {"point", "x_m", "y_m", "z_m"}, {});
  std::vector<CheckPoint> points;
  while (table.next()) {
    CheckPoint p;
    p.point = table.integer("point");
    p.site_m = Eigen::Vector3d(table.number("x_m"), table.number("y_m"), table.number("z_m"));
    points.push_back(p);
  }
  return points;
}

void writePointsCsv(const std::string& path, const std::vector<CheckPoint>& points) {
  std::ostringstream out;
  out << "point,x_m,y_m,z_m\n";
  for (const CheckPoint& p : points) {
    out << p.point << ',' << formatDouble(p.site_m.x()) << ',' << formatDouble(p.site_m.y()) << ','
        << formatDouble(p.site_m.z()) << '\n';
  }
  writeDatasetFile(path, out.str());
}

std::vector<ImageObservation> readObservationsCsv(const std::string& path) {
  CsvTable table(path, {"point", "image", "sample_px", "line_px"}, {"kind"});
  const bool with_kind = table.has("kind");
  std::vector<ImageObservation> observations;
  while (table.next()) {
    ImageObservation o;
    o.point = table.integer("point");
    o.image = table.cell("image");
    if (o.image.empty()) table.fail("image", "empty image stem");
    o.sample_px = table.number("sample_px");
    o.line_px = table.number("line_px");
    if (with_kind) o.kind = table.cell("kind");
    observations.push_back(std::move(o));
  }
  return observations;
}

void writeObservationsCsv(const std::string& path, const std::vector<ImageObservation>& observations, bool with_kind) {
  std::ostringstream out;
  out << (with_kind ? "point,image,sample_px,line_px,kind\n" : "point,image,sample_px,line_px\n");
  for (const ImageObservation& o : observations) {
    out << o.point << ',' << o.image << ',' << formatDouble(o.sample_px) << ',' << formatDouble(o.line_px);
    if (with_kind) out << ',' << o.kind;
    out << '\n';
  }
  writeDatasetFile(path, out.str());
}

}  // namespace areomap
