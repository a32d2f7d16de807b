// Atomic output, range flags and CSV input.
#include "pvdf/core/io.hpp"

#include "pvdf/core/error.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include <sys/stat.h>
#include <unistd.h>

namespace pvdf {

namespace fs = std::filesystem;

namespace {

std::string temporary_name_for(const std::string& path) {
  std::random_device rd;
  std::ostringstream os;
  os << path << ".tmp." << ::getpid() << "." << std::hex << rd();
  return os.str();
}

}  // namespace

std::string output_path_problem(const std::string& path) {
  if (path.empty()) return "is empty; give a file name";
  struct stat st {};
  if (::lstat(path.c_str(), &st) == 0) {
    if (S_ISLNK(st.st_mode)) {
      return "is a symbolic link: writing would replace the link, not its target; give the file's real path or "
             "another name";
    }
    if (S_ISDIR(st.st_mode)) return "is a folder; give a file name";
    if (!S_ISREG(st.st_mode)) {
      return "is a device or special file, not a regular file: it would be replaced; give a regular file name";
    }
  }
  const fs::path parent = fs::path(path).parent_path();
  const fs::path folder = parent.empty() ? fs::path(".") : parent;
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) {
    return "cannot be written: folder " + folder.string() + " does not exist; create it or choose another path";
  }
  if (::access(folder.c_str(), W_OK) != 0) {
    return "cannot be written: folder " + folder.string() + " is not writable; choose a writable folder";
  }
  return "";
}

void check_output_path(const std::string& path, const std::string& what) {
  const std::string problem = output_path_problem(path);
  if (!problem.empty()) throw InputError(what + ": " + quote_cell(path) + " " + problem);
}

std::string quote_cell(const std::string& text) {
  if (text.size() <= max_quoted_chars) return escape_control_bytes(text);
  return escape_control_bytes(text.substr(0, max_quoted_chars)) + "... (" + std::to_string(text.size()) + " characters)";
}

void check_csv_file(const std::string& path, const std::string& what, std::size_t max_rows) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(what + ": " + quote_cell(path) + ": cannot open the file; check the path and its permissions");
  const std::string where = what + ": " + quote_cell(path);
  std::string line;
  std::size_t line_no = 0, n_rows = 0;
  bool have_header = false;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.find('\0') != std::string::npos) {
      throw InputError(where + ":" + std::to_string(line_no) + ": holds a NUL byte; is this a CSV text file? remove it");
    }
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    const std::vector<std::string> fields = split_csv_line(line);
    for (const auto& f : fields) {
      if (f.size() > max_csv_cell_chars) {
        throw InputError(where + ":" + std::to_string(line_no) + ": a cell of " + std::to_string(f.size()) +
                         " characters ('" + quote_cell(f) + "'), the limit is " + std::to_string(max_csv_cell_chars) +
                         "; cells hold one number or one column name");
      }
    }
    if (!have_header) {
      for (std::size_t i = 0; i < fields.size(); ++i) {
        for (std::size_t j = 0; j < i; ++j) {
          if (fields[i] == fields[j] && !fields[i].empty()) {
            throw InputError(where + ":" + std::to_string(line_no) + ": column '" + quote_cell(fields[i]) +
                             "' appears twice in the header (columns " + std::to_string(j + 1) + " and " +
                             std::to_string(i + 1) + "); keep one of them");
          }
        }
      }
      have_header = true;
      if (max_rows == 0) return;
      continue;
    }
    if (++n_rows > max_rows) {
      throw InputError(where + ": more than " + std::to_string(max_rows) +
                       " data rows (the limit of a whole-file input); split the file or thin it");
    }
  }
}

void make_directories(const std::string& path) {
  if (path.empty()) return;
  std::error_code ec;
  fs::create_directories(path, ec);
  if (ec) throw InputError(path + ": cannot create the folder (" + ec.message() + "); choose a writable place");
}

void write_path_atomically(const std::string& path, const std::function<void(const std::string&)>& write) {
  const fs::path target(path);
  {
    // Never replace a device, a symbolic link or a folder (only a regular file, or nothing).
    struct stat st {};
    if (::lstat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {
      throw InputError(quote_cell(path) + " " + output_path_problem(path));
    }
  }
  if (target.has_parent_path()) {
    std::error_code ec;
    if (!fs::exists(target.parent_path(), ec)) {
      throw InputError(path + ": folder " + target.parent_path().string() +
                       " does not exist; create it or choose another output path");
    }
  }
  const std::string tmp = temporary_name_for(path);
  try {
    write(tmp);
  } catch (...) {
    std::remove(tmp.c_str());
    throw;
  }
  {
    // Checked again just before the rename: the target may have changed during a long write.
    struct stat st {};
    if (::lstat(path.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {
      std::remove(tmp.c_str());
      throw InputError(quote_cell(path) + " " + output_path_problem(path) + " (it changed while the output was written)");
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const std::string why = std::strerror(errno);
    std::remove(tmp.c_str());
    throw InputError(path + ": cannot write the file (" + why + "); choose a writable path");
  }
}

void write_file_atomically(const std::string& path, const std::function<void(std::ostream&)>& write) {
  write_path_atomically(path, [&](const std::string& tmp) {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw InputError(path + ": cannot open for writing; check the folder and its permissions");
    write(out);
    out.flush();
    if (!out) throw InputError(path + ": write failed (disk full?); free space and run again");
  });
}

std::string format_g(double x) { return format_printf("%g", x); }

std::string format_printf(const char* format, double x) {
  char buf[128];
  std::snprintf(buf, sizeof buf, format, x);
  return buf;
}

bool parse_finite(const std::string& text, double& value) {
  if (text.empty()) return false;
  const char* begin = text.c_str();
  char* end = nullptr;
  errno = 0;
  const double x = std::strtod(begin, &end);
  if (end == begin) return false;
  while (*end == ' ' || *end == '\t' || *end == '\r') ++end;
  if (*end != '\0') return false;
  if (!std::isfinite(x)) return false;
  value = x;
  return true;
}

std::vector<double> parse_number_list(const std::string& text, const std::string& what, std::size_t count) {
  std::vector<double> out;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    double x = 0;
    const auto b = item.find_first_not_of(" \t");
    const auto e = item.find_last_not_of(" \t");
    const std::string t = b == std::string::npos ? "" : item.substr(b, e - b + 1);
    if (!parse_finite(t, x)) {
      throw InputError(what + " = '" + quote_cell(text) + "': '" + quote_cell(t) +
                       "' is not a finite number; write numbers separated by commas");
    }
    out.push_back(x);
  }
  if (out.empty()) throw InputError(what + " = '" + quote_cell(text) + "' is empty; give at least one number");
  if (count != 0 && out.size() != count) {
    throw InputError(what + " = '" + quote_cell(text) + "' has " + std::to_string(out.size()) + " numbers; it needs exactly " +
                     std::to_string(count));
  }
  return out;
}

std::vector<double> parse_range(const std::string& text, const std::string& what, std::size_t max_count) {
  std::vector<std::string> parts;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ':')) parts.push_back(item);
  double start = 0, step = 0, stop = 0;
  if (parts.size() != 3 || !parse_finite(parts[0], start) || !parse_finite(parts[1], step) ||
      !parse_finite(parts[2], stop)) {
    throw InputError(what + " = '" + quote_cell(text) + "' must be START:STEP:STOP with three finite numbers, e.g. 0:5:90");
  }
  if (step == 0 || (stop - start) / step < 0) {
    throw InputError(what + " = '" + quote_cell(text) + "': STEP must be non-zero and lead from START to STOP");
  }
  const double n_real = std::floor((stop - start) / step + 1e-9) + 1;
  if (n_real > static_cast<double>(max_count)) {
    throw InputError(what + " = '" + quote_cell(text) + "' gives " + std::to_string(static_cast<long long>(n_real)) +
                     " values; the limit is " + std::to_string(max_count) + ": use a larger STEP");
  }
  std::vector<double> out;
  for (long i = 0; i < static_cast<long>(n_real); ++i) out.push_back(start + i * step);
  return out;
}

namespace {

/// Splits one CSV line (RFC 4180 quoting: "a, b" is one field, "" inside quotes is one quote);
/// a UTF-8 byte-order mark at its start and a trailing CR are dropped, unquoted fields trimmed.
/// Returns false for an unterminated quote.
bool split_fields(const std::string& line, std::vector<std::string>& out) {
  out.clear();
  std::size_t i = line.compare(0, 3, "\xEF\xBB\xBF") == 0 ? 3 : 0;
  std::size_t end = line.size();
  if (end > i && line[end - 1] == '\r') --end;
  for (;;) {
    while (i < end && (line[i] == ' ' || line[i] == '\t')) ++i;
    std::string field;
    if (i < end && line[i] == '"') {
      ++i;
      bool closed = false;
      while (i < end) {
        if (line[i] == '"') {
          if (i + 1 < end && line[i + 1] == '"') {
            field += '"';
            i += 2;
            continue;
          }
          closed = true;
          ++i;
          break;
        }
        field += line[i++];
      }
      if (!closed) return false;
      while (i < end && line[i] != ',') field += line[i++];  // text after the closing quote
      const auto e = field.find_last_not_of(" \t");
      field.erase(e == std::string::npos ? 0 : e + 1);
    } else {
      const std::size_t comma = line.find(',', i);
      const std::size_t stop = comma == std::string::npos || comma > end ? end : comma;
      field = line.substr(i, stop - i);
      i = stop;
      const auto e = field.find_last_not_of(" \t");
      field.erase(e == std::string::npos ? 0 : e + 1);
    }
    out.push_back(field);
    if (i >= end) break;
    ++i;  // the comma
    if (i == end) {
      out.emplace_back();
      break;
    }
  }
  return true;
}

}  // namespace

std::vector<std::string> split_csv_line(const std::string& line) {
  std::vector<std::string> out;
  if (!split_fields(line, out)) {
    // Unterminated quote: keep the raw text as one trailing field, which no number parse accepts.
    split_fields(line.substr(0, line.rfind('"')), out);
    out.push_back(line.substr(line.rfind('"')));
  }
  return out;
}

std::size_t CsvTable::column(const std::string& name) const {
  for (std::size_t i = 0; i < columns.size(); ++i) {
    if (columns[i] == name) return i;
  }
  std::string have;
  for (const auto& c : columns) have += (have.empty() ? "" : ",") + c;
  throw InputError(source + ": no column '" + name + "' in the header (" + have + "); add it (see docs)");
}

bool CsvTable::has_column(const std::string& name) const {
  for (const auto& c : columns) {
    if (c == name) return true;
  }
  return false;
}

CsvTable read_csv(std::istream& in, const std::string& source, BadRowPolicy policy,
                  std::vector<std::string>* skipped) {
  CsvTable t;
  t.source = source;
  std::string line;
  std::size_t line_no = 0;
  bool have_header = false;
  std::vector<std::string> fields;
  while (std::getline(in, line)) {
    ++line_no;
    if (line_no == 1 && line.compare(0, 3, "\xEF\xBB\xBF") == 0) line.erase(0, 3);  // UTF-8 byte-order mark
    const auto first = line.find_first_not_of(" \t\r");
    if (first == std::string::npos || line[first] == '#') continue;
    if (!split_fields(line, fields)) {
      const std::string msg = source + ":" + std::to_string(line_no) + ": unterminated quote (a field opens \" and never closes it)";
      if (policy == BadRowPolicy::refuse || !have_header) throw InputError(msg + "; close the quote or remove the row");
      if (skipped) skipped->push_back(msg);
      continue;
    }
    if (!have_header) {
      for (const auto& f : fields) {
        if (f.empty()) throw InputError(source + ":" + std::to_string(line_no) + ": empty column name in the header; name every column");
        if (escape_control_bytes(f) != f) {
          throw InputError(source + ":" + std::to_string(line_no) + ": column name '" + quote_cell(f) +
                           "' holds control bytes; is this a CSV file?");
        }
      }
      for (std::size_t i = 0; i < fields.size(); ++i) {
        for (std::size_t j = 0; j < i; ++j) {
          if (fields[i] == fields[j]) {
            throw InputError(source + ":" + std::to_string(line_no) + ": column '" + quote_cell(fields[i]) +
                             "' appears twice in the header; keep one of them");
          }
        }
      }
      t.columns = fields;
      have_header = true;
      continue;
    }
    std::string problem;
    std::vector<double> row;
    if (fields.size() != t.columns.size()) {
      problem = "has " + std::to_string(fields.size()) + " fields, the header has " + std::to_string(t.columns.size());
    } else {
      for (std::size_t j = 0; j < fields.size(); ++j) {
        double x = 0;
        if (!parse_finite(fields[j], x)) {
          problem = "column " + t.columns[j] + " = '" + escape_control_bytes(fields[j].substr(0, 40)) + "' is not a finite number";
          break;
        }
        row.push_back(x);
      }
    }
    if (!problem.empty()) {
      const std::string msg = source + ":" + std::to_string(line_no) + ": " + problem;
      if (policy == BadRowPolicy::refuse) throw InputError(msg + "; fix or remove the row");
      if (skipped) skipped->push_back(msg);
      continue;
    }
    t.rows.push_back(std::move(row));
    t.line_numbers.push_back(line_no);
  }
  if (!have_header) throw InputError(source + ": no header row; the first line must name the columns");
  return t;
}

CsvTable read_csv(const std::string& path, BadRowPolicy policy, std::vector<std::string>* skipped) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot open the file; check the path and its permissions");
  return read_csv(in, path, policy, skipped);
}

}  // namespace pvdf
