// Flat lookup map files: the binary block and its C-header form (docs/lookup.md §8).
#include "pvdf/mapping/flat_map_file.hpp"

#include "pvdf/core/io.hpp"
#include "pvdf/mapping/flat_map.hpp"

#include <cctype>
#include <cstdio>
#include <ostream>
#include <string>

namespace pvdf::mapping {

void write_flat_map(const std::string& path, const ChargeMap& map, const std::string& source) {
  const std::vector<unsigned char> bytes = encode_flat_map(map, source);
  write_file_atomically(path, [&](std::ostream& out) { out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size())); });
}

std::string c_identifier(const std::string& text) {
  std::string id;
  for (const char c : text) id += (std::isalnum(static_cast<unsigned char>(c)) && static_cast<unsigned char>(c) < 0x80) || c == '_' ? c : '_';
  if (id.empty()) return "pvdf_map";
  if (std::isdigit(static_cast<unsigned char>(id[0]))) id = "_" + id;
  return id;
}

std::string flat_map_c_header(const std::vector<unsigned char>& bytes, const ChargeMap& map, const std::string& symbol,
                              const std::string& source) {
  std::string guard = symbol + "_H";
  for (auto& c : guard) c = char(std::toupper(static_cast<unsigned char>(c)));
  // Names and the source path go into a comment: no byte may end it or the line.
  auto comment_safe = [](const std::string& text) {
    std::string out;
    for (const char c : text) out += (static_cast<unsigned char>(c) < 0x20 || c == '*' || c == 0x7f) ? '_' : c;
    return out;
  };
  std::string names;
  for (const auto& n : map.electrode_names) names += (names.empty() ? "" : ", ") + comment_safe(n);
  char line[256];
  const unsigned version = unsigned(bytes[8]) | unsigned(bytes[9]) << 8 | unsigned(bytes[10]) << 16 | unsigned(bytes[11]) << 24;
  std::string h = "/* pvdfkit flat lookup map (format version " + std::to_string(version) +
                  ", little-endian; layout: pvdfkit docs/lookup.md).\n";
  h += " * Exported from " + comment_safe(source) + " by `pvdfkit export-map`.\n";
  std::snprintf(line, sizeof line, " * Grid %zu x %zu points, %zu force levels, %zu electrodes: ", map.nx(), map.ny(), map.nf(), map.ne());
  h += line + names + ".\n";
  h += " * Load it with pvdf::mapping::decode_flat_map(" + symbol + ", " + symbol + "_SIZE, \"" + symbol + "\"). */\n";
  h += "#ifndef " + guard + "\n#define " + guard + "\n\n";
  std::snprintf(line, sizeof line, "#define %s_SIZE %zuu\n\n", symbol.c_str(), bytes.size());
  h += line;
  h += "static const unsigned char " + symbol + "[" + symbol + "_SIZE] = {\n";
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    std::snprintf(line, sizeof line, "%s0x%02x%s", i % 16 == 0 ? "  " : "", bytes[i], i + 1 == bytes.size() ? "\n" : (i % 16 == 15 ? ",\n" : ","));
    h += line;
  }
  h += "};\n\n#endif /* " + guard + " */\n";
  return h;
}

void write_flat_map_c_header(const std::string& path, const ChargeMap& map, const std::string& symbol, const std::string& source) {
  const std::string text = flat_map_c_header(encode_flat_map(map, source), map, symbol, source);
  write_file_atomically(path, [&](std::ostream& out) { out << text; });
}

}  // namespace pvdf::mapping
