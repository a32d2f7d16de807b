// Map generation, checkpoints: the hash that ties a checkpoint to the scene and options, the
// checkpoint files (a text header, then records of float64), the records that go in and out of
// the map, and the resume from the files of an interrupted run.
#include "generator.hpp"

#include "pvdf/core/assert.hpp"
#include "pvdf/core/error.hpp"
#include "pvdf/core/io.hpp"
#include "pvdf/mesh/film_mesh.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace pvdf::mapping::detail {

std::string hex(std::uint64_t v) {
  char buf[20];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

// ---------------------------------------------------------------------------------------------
// Checkpoint files: a text header, then `records` × `record_doubles` float64 (native order).
// The header's last line is a checksum (FNV-1a 64) over the header lines before it and every
// record byte, so a damaged, truncated or edited file is refused instead of resumed.

constexpr const char* checkpoint_magic = "pvdfkit-map-checkpoint 3";
constexpr const char* checkpoint_magic_v2 = "pvdfkit-map-checkpoint 2";  // before checksums

/// FNV-1a 64 continued over raw bytes (prime 2^40 + 2^8 + 0xb3).
std::uint64_t fnv1a_bytes(std::uint64_t h, const char* data, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) {
    h ^= static_cast<unsigned char>(data[i]);
    h *= 1099511628211ull;
  }
  return h;
}
constexpr std::uint64_t fnv1a_offset_basis = 14695981039346656037ull;
/// The run hash's start: the offset basis one digit short, a slip of the first version kept
/// because the hash names existing checkpoints (a resume would otherwise start afresh).
constexpr std::uint64_t run_hash_basis = 1469598103934665603ull;

std::string checkpoint_header(const std::string& hash, std::size_t record_doubles, std::size_t n_records) {
  return std::string(checkpoint_magic) + "\nhash " + hash + "\nrecord_doubles " + std::to_string(record_doubles) +
         "\nrecords " + std::to_string(n_records) + "\n";
}

std::uint64_t checkpoint_checksum(const std::string& header, const std::vector<double>& records) {
  const std::uint64_t h = fnv1a_bytes(fnv1a_offset_basis, header.data(), header.size());
  return fnv1a_bytes(h, reinterpret_cast<const char*>(records.data()), records.size() * sizeof(double));
}

void write_checkpoint(const std::string& path, const std::string& hash, const Layout& layout,
                      const std::vector<double>& records) {
  PVDF_ASSERT(layout.size() > 0 && records.size() % layout.size() == 0, "a checkpoint holds whole records");
  const std::string header = checkpoint_header(hash, layout.size(), records.size() / layout.size());
  const std::string checksum = hex(checkpoint_checksum(header, records));
  write_file_atomically(path, [&](std::ostream& out) {
    out << header << "checksum " << checksum << "\n";
    out.write(reinterpret_cast<const char*>(records.data()), std::streamsize(records.size() * sizeof(double)));
  });
}

namespace {

/// One header line of at most 200 bytes (a hostile file without newlines is not read whole).
bool read_header_line(std::istream& in, std::string& line) {
  line.clear();
  for (char c; in.get(c);) {
    if (c == '\n') return true;
    if (line.size() >= 200) return false;
    line += c;
  }
  return false;
}

/// "KEY VALUE" with VALUE all decimal digits (at most 18: no overflow), else false.
bool parse_count_line(const std::string& line, const std::string& key, std::size_t& value) {
  if (line.compare(0, key.size() + 1, key + " ") != 0) return false;
  const std::string digits = line.substr(key.size() + 1);
  if (digits.empty() || digits.size() > 18) return false;
  for (const char c : digits) {
    if (c < '0' || c > '9') return false;
  }
  value = static_cast<std::size_t>(std::stoull(digits));
  return true;
}

}  // namespace

std::vector<double> read_checkpoint(const std::string& path, const std::string& hash, const Layout& layout) {
  // Every refusal names the file and says how to start afresh.
  const std::string afresh = "; delete it (or pass --no-resume) to start the map afresh";
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open the checkpoint; check permissions, or delete it");
  std::string magic, hash_line, doubles_line, records_line, checksum_line;
  const bool header_read = read_header_line(in, magic);
  if (magic == checkpoint_magic_v2) {
    throw InputError(path + ": a checkpoint of an older pvdfkit (format 2, without a checksum), not resumed" + afresh);
  }
  if (!header_read || magic != checkpoint_magic) {
    throw InputError(path + ": not a pvdfkit map checkpoint (first line '" + quote_cell(magic.substr(0, 40)) + "')" +
                     afresh + ", or choose another --checkpoint file");
  }
  if (!read_header_line(in, hash_line) || hash_line.compare(0, 5, "hash ") != 0) {
    throw InputError(path + ": damaged checkpoint header (line 2 is not 'hash ...')" + afresh);
  }
  const std::string file_hash = hash_line.substr(5);
  if (file_hash != hash) {
    throw InputError(path + ": checkpoint hash " + quote_cell(file_hash) +
                     " was written for a different scene or map options (this run: " + hash +
                     "); delete it, start afresh without resuming, or choose another checkpoint file");
  }
  std::size_t record_doubles = 0, n_records = 0;
  if (!read_header_line(in, doubles_line) || !parse_count_line(doubles_line, "record_doubles", record_doubles) ||
      !read_header_line(in, records_line) || !parse_count_line(records_line, "records", n_records) ||
      !read_header_line(in, checksum_line) || checksum_line.compare(0, 9, "checksum ") != 0) {
    throw InputError(path + ": damaged checkpoint header (record_doubles, records and checksum lines expected)" + afresh);
  }
  if (record_doubles != layout.size()) {
    throw InputError(path + ": checkpoint record size " + std::to_string(record_doubles) + " does not match " +
                     std::to_string(layout.size()) + afresh);
  }
  // The allocation follows the bytes the file holds, never the header's count alone.
  const std::streamoff data_start = in.tellg();
  in.seekg(0, std::ios::end);
  const std::streamoff file_end = in.tellg();
  in.seekg(data_start);
  const std::size_t record_bytes = record_doubles * sizeof(double);
  const std::size_t held_bytes = file_end > data_start ? std::size_t(file_end - data_start) : 0;
  if (n_records > held_bytes / record_bytes || n_records * record_bytes != held_bytes) {
    throw InputError(path + ": checkpoint truncated or damaged (header announces " + std::to_string(n_records) +
                     " records, the file holds " + std::to_string(held_bytes) + " bytes of records, " +
                     std::to_string(held_bytes / record_bytes) + " records and " + std::to_string(held_bytes % record_bytes) +
                     " bytes)" + afresh);
  }
  std::vector<double> data(n_records * record_doubles);
  in.read(reinterpret_cast<char*>(data.data()), std::streamsize(data.size() * sizeof(double)));
  if (!in || std::size_t(in.gcount()) != data.size() * sizeof(double)) {
    throw InputError(path + ": checkpoint could not be read whole (" + std::to_string(n_records) + " records announced)" + afresh);
  }
  const std::string expected = hex(checkpoint_checksum(checkpoint_header(file_hash, record_doubles, n_records), data));
  if (checksum_line.substr(9) != expected) {
    throw InputError(path + ": checkpoint checksum " + quote_cell(checksum_line.substr(9, 40)) +
                     " does not match its content (" + expected + "): the file is damaged or was edited, not resumed" +
                     afresh);
  }
  return data;
}

std::string rank_checkpoint_path(const std::string& base, int rank, int size) {
  return size == 1 ? base : base + ".rank" + std::to_string(rank);
}

// The base file and every `<base>.rank<digits>` beside it.
std::vector<std::string> existing_checkpoints(const std::string& base) {
  namespace fs = std::filesystem;
  std::vector<std::string> out;
  std::error_code ec;
  if (fs::exists(base, ec)) out.push_back(base);
  const fs::path p(base);
  const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
  const std::string prefix = p.filename().string() + ".rank";
  if (!fs::is_directory(dir, ec)) return out;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.size() <= prefix.size() || name.compare(0, prefix.size(), prefix) != 0) continue;
    const std::string tail = name.substr(prefix.size());
    if (std::all_of(tail.begin(), tail.end(), [](char c) { return c >= '0' && c <= '9'; })) {
      out.push_back((dir / name).string());
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

void Generator::store_record(const double* rec, bool resumed) {
  const std::size_t p = std::size_t(rec[Layout::point_index]);
  const std::size_t ne = layout_.ne;
  PVDF_ASSERT(rec[Layout::point_index] >= 0 && p < grid_.nx * grid_.ny,
              "a record is stored at a point of the grid (resume() checks the files' records)");
  for (std::size_t f = 0; f < layout_.nf; ++f) {
    const double* r = layout_.level(rec, f);
    const std::size_t pt = f * grid_.nx * grid_.ny + p;
    map_.status[pt] = std::uint8_t(r[Layout::status]);
    provenance_[pt] = std::uint8_t(r[Layout::provenance]);
    map_.deflection_at_load_m[pt] = r[Layout::deflection];
    node_model_[pt] = std::uint8_t(r[Layout::model]);
    deflection_error_[pt] = r[Layout::deflection_error];
    for (std::size_t k = 0; k < ne; ++k) {
      map_.charge_C[pt * ne + k] = r[Layout::charges + k];
      map_.estimated_charge_error_C[pt * ne + k] = r[layout_.errors() + k];
    }
    if (resumed) ++n_resumed_points_;
  }
  known_[p] = 1;
}

std::vector<double> Generator::known_records(bool only_this_run) const {
  std::vector<double> out;
  const std::size_t ne = layout_.ne, n = grid_.nx * grid_.ny;
  for (std::size_t p = 0; p < n; ++p) {
    if (!known_[p] || (only_this_run && !this_run_[p])) continue;
    out.push_back(double(p));
    for (std::size_t f = 0; f < layout_.nf; ++f) {
      const std::size_t pt = f * n + p;
      out.push_back(map_.status[pt]);
      out.push_back(provenance_[pt]);
      out.push_back(map_.deflection_at_load_m[pt]);
      out.push_back(node_model_[pt]);
      out.push_back(deflection_error_[pt]);
      for (std::size_t k = 0; k < ne; ++k) out.push_back(map_.charge_C[pt * ne + k]);
      for (std::size_t k = 0; k < ne; ++k) out.push_back(map_.estimated_charge_error_C[pt * ne + k]);
    }
    PVDF_ASSERT(out.size() % layout_.size() == 0, "a record must have the layout's size");
  }
  return out;
}

// Caller holds mutex_ (or runs single-threaded).
void Generator::maybe_checkpoint(bool force) {
  if (o_.checkpoint_path.empty()) return;
  const auto now = std::chrono::steady_clock::now();
  if (!force && std::chrono::duration<double>(now - last_checkpoint_).count() < o_.checkpoint_interval_s) return;
  write_checkpoint(rank_checkpoint_path(o_.checkpoint_path, rank_, size_), hash_, layout_, known_records(false));
  last_checkpoint_ = now;
}

// What ties a checkpoint to this run: everything that changes a point's value.
std::string Generator::run_hash() const {
  std::ostringstream key;
  key.precision(17);
  key << map_.scene_json << "|grid " << grid_.i0 << ' ' << grid_.j0 << ' ' << grid_.nx << ' ' << grid_.ny << ' '
      << grid_.spacing << "|forces";
  for (double f : o_.forces_N) key << ' ' << f;
  key << "|model " << fem::model_name(sweep_options_.solver.model) << "|tol " << tolerance_ << "|margin " << margin_
      << "|scaling " << o_.use_force_scaling << ' ' << o_.scaling_check_stride << "|sym " << sym_.about_x << sym_.about_y
      << "|rim " << int(sweep_options_.rim_model) << ' ' << sweep_options_.rim_size_m << ' ' << sweep_options_.rim_grading
      << "|direct " << option_name(o_.direct_solves) << "|probe " << sweep_options_.probe_size_m;
  // The clamp-layer condition (off with PVDF_CLAMP_LAYER=rim-graded) changes near-clamp values.
  const fem::SweepSetup& setup = sweeps_[0]->setup();
  if (setup.rim_model_available) key << "|clamp " << setup.clamp_layer_condition;
  if (o_.mesh) {  // another starting mesh changes every value
    key << "|mesh " << o_.mesh->n_cells();
    for (const auto& v : o_.mesh->vertices) key << ' ' << v[0] << ' ' << v[1];
  }
  const std::string text = key.str();
  return hex(fnv1a_bytes(run_hash_basis, text.data(), text.size()));
}

// Takes the records of every checkpoint file of this run (one per rank that wrote one).
void Generator::resume() {
  if (o_.checkpoint_path.empty() || !o_.resume) return;
  const std::size_t n = grid_.nx * grid_.ny, nf = layout_.nf;
  for (const auto& file : existing_checkpoints(o_.checkpoint_path)) {
    const std::vector<double> data = read_checkpoint(file, hash_, layout_);
    for (std::size_t r = 0; r < data.size(); r += layout_.size()) {
      const double* rec = data.data() + r;
      const double pd = rec[Layout::point_index];
      const bool index_ok = pd >= 0 && pd < double(n) && pd == std::floor(pd);
      bool values_ok = index_ok && map_.mask[std::size_t(pd)] != 0;
      for (std::size_t f = 0; values_ok && f < nf; ++f) {
        const double* level = layout_.level(rec, f);
        const double st = level[Layout::status];
        values_ok = st == double(PointStatus::ok) || st == double(PointStatus::not_converged);
        // A solved point has finite values (a checksum does not vouch for what was written).
        for (std::size_t k = 0; values_ok && st == double(PointStatus::ok) && k < layout_.ne; ++k) {
          values_ok = std::isfinite(level[Layout::charges + k]);
        }
      }
      if (!values_ok) {
        throw InputError(file + ": checkpoint record " + std::to_string(r / layout_.size()) +
                         " is invalid (grid index, status or a solved charge); delete the checkpoint (or pass "
                         "--no-resume) to start the map afresh");
      }
      if (known_[std::size_t(pd)]) continue;  // duplicates across rank files hold the same values
      store_record(rec, true);
    }
  }
}

}  // namespace pvdf::mapping::detail

namespace pvdf::mapping {

void remove_checkpoint_files(const std::string& checkpoint_path) {
  if (checkpoint_path.empty()) return;
  for (const auto& f : detail::existing_checkpoints(checkpoint_path)) std::remove(f.c_str());
}

}  // namespace pvdf::mapping
