// Fixture files of the hostile-input table (see hostile_fixtures.hpp).
#include "hostile_fixtures.hpp"

#include "pvdf/core/scene.hpp"

#include <nlohmann/json.hpp>

#include <fstream>

namespace pvdf::test {

namespace {

/// A string literal with its embedded NUL bytes kept.
template <std::size_t N>
std::string bytes(const char (&s)[N]) {
  return std::string(s, N - 1);
}

void write(const std::filesystem::path& p, const std::string& text) {
  std::ofstream out(p, std::ios::binary);
  out << text;
}

}  // namespace

std::string seed001_with(const std::string& patch_json) {
  nlohmann::json j = nlohmann::json::parse(pvdf::default_scene_json());
  j.merge_patch(nlohmann::json::parse(patch_json));
  return j.dump(1);
}

void write_hostile_fixtures(const std::filesystem::path& d) {
  write(d / "good.json", pvdf::default_scene_json());
  // Syntax: truncated large files, nesting, garbage, empty, NaN, not an object.
  std::string big = seed001_with("{}");
  big.insert(big.find("\"name\""), "\"description\": \"" + std::string(40000, 'x') + "\",\n");
  write(d / "trunc40k.json", big.substr(0, big.size() - 2));
  write(d / "trunc_half.json", big.substr(0, big.size() / 2));
  write(d / "deep_array.json", std::string(100000, '['));
  std::string deep_obj;
  for (int i = 0; i < 50000; ++i) deep_obj += "{\"a\":";
  write(d / "deep_object.json", deep_obj);
  std::string nested_ok = "{\"name\": ";
  for (int i = 0; i < 20000; ++i) nested_ok += "[";
  for (int i = 0; i < 20000; ++i) nested_ok += "]";
  write(d / "deep_valid.json", nested_ok + "}");
  write(d / "garbage.json", bytes("\x01\x02\x1b[31mRED\x00\x7fgarbage\xff\xfe"));
  write(d / "empty.json", "");
  write(d / "nan.json", "{\"membrane\": {\"thickness_m\": NaN}}");
  write(d / "array.json", "[1, 2, 3]");
  write(d / "huge_number.json", "{\"membrane\": {\"radius_m\": 1e400}}");
  write(d / "dup_key.json", "{\"membrane\": {\"radius_m\": 0.045, \"radius_m\": 0.03}}");
  write(d / "dup_top.json", "{\"model\": {}, \"model\": {\"tolerance\": 0.1}}");
  write(d / "unknown_key.json", seed001_with("{\"membrane\": {\"thicknes_m\": 2.5e-5}}"));
  write(d / "bad_utf8.json", "{\"name\": \"\xc3\x28\"}");
  // Geometry: electrodes outside, across the rim, overlapping; sizes out of range.
  write(d / "e_outside.json", seed001_with(R"({"electrodes": [{"name": "A", "center_m": [0, 0.06]}]})"));
  write(d / "e_crossing.json", seed001_with(R"({"electrodes": [{"name": "A", "center_m": [0, 0.0445]}]})"));
  write(d / "e_overlap.json", seed001_with(R"({"electrodes": [{"name": "A", "center_m": [0, 0.01]},
                                                              {"name": "B", "center_m": [0.001, 0.0105]}]})"));
  write(d / "e_tiny.json", seed001_with(R"({"electrodes": [{"name": "A", "center_m": [0, 0.01], "size_m": [1e-12, 0.002]}]})"));
  write(d / "e_tiny_ok.json", seed001_with(R"({"electrodes": [{"name": "X", "center_m": [0, 0.01]}]})"));
  write(d / "radius_huge.json", seed001_with(R"({"membrane": {"radius_m": 1e308}})"));
  write(d / "radius_tiny.json", seed001_with(R"({"membrane": {"radius_m": 1e-9}})"));
  write(d / "rect_huge.json", seed001_with(R"({"membrane": {"shape": "rectangle", "size_m": [1e300, 0.09], "radius_m": null}})"));
  write(d / "probe_1e-20.json", seed001_with(R"({"probe": {"radius_m": 1e-20}})"));
  write(d / "probe_1e-300.json", seed001_with(R"({"probe": {"radius_m": 1e-300}})"));
  write(d / "probe_huge.json", seed001_with(R"({"probe": {"radius_m": 0.04}})"));
  write(d / "load_rim.json", seed001_with(R"({"loads": [{"position_m": [0, 0.044], "force_N": 1}]})"));
  write(d / "load_outside.json", seed001_with(R"({"loads": [{"position_m": [0, 0.05], "force_N": 1}]})"));
  write(d / "e_short_edge.json", seed001_with(R"({"electrodes": [{"name": "P", "shape": "polygon",
      "vertices_m": [[0, 0.01], [0.002, 0.01], [0.002, 0.012], [1e-13, 0.012], [0, 0.012]]}]})"));
  write(d / "size_min_tiny.json", seed001_with(R"({"mesh": {"size_min_m": 1e-9}})"));
  write(d / "tolerance_tiny.json", seed001_with(R"({"model": {"tolerance": 1e-12}})"));
  write(d / "thickness_neg.json", seed001_with(R"({"membrane": {"thickness_m": -2.5e-5}})"));
  // Gmsh meshes for `solve --mesh` (format 2.2 by hand: a 60 mm square of two cells).
  const std::string msh_head = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$PhysicalNames\n2\n1 1 \"rim\"\n2 1 \"film\"\n"
                               "$EndPhysicalNames\n$Nodes\n4\n1 -0.03 -0.03 0\n2 0.03 -0.03 0\n3 0.03 0.03 0\n"
                               "4 -0.03 0.03 0\n$EndNodes\n";
  const std::string rim = "1 1 2 1 1 1 2\n2 1 2 1 1 2 3\n3 1 2 1 1 3 4\n4 1 2 1 1 4 1\n";
  write(d / "triangles.msh", msh_head + "$Elements\n6\n" + rim + "5 2 2 1 1 1 2 3\n6 2 2 1 1 1 3 4\n$EndElements\n");
  write(d / "bowtie.msh", msh_head + "$Elements\n5\n" + rim + "5 3 2 1 1 1 2 4 3\n$EndElements\n");
  write(d / "square.msh", msh_head + "$Elements\n5\n" + rim + "5 3 2 1 1 1 2 3 4\n$EndElements\n");
  std::string no_rim = msh_head;
  no_rim.replace(no_rim.find("2\n1 1 \"rim\"\n"), 12, "1\n");
  write(d / "no_rim.msh", no_rim + "$Elements\n1\n5 3 2 1 1 1 2 3 4\n$EndElements\n");
  write(d / "not_gmsh.msh", "hello, I am not a mesh\n");
  write(d / "garbage.msh", bytes("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n\x01\x1b[2Jgarbage\x00\xff\n"));
  write(d / "huge_count.msh", "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n900000000000\n1 0 0 0\n$EndNodes\n");
  // CSV and filter files.
  write(d / "garbage.csv", bytes("x_m,y_m,force_N,charge_A_C\n0.1,\x01\x1b[2J\x00,1,2\n"));
  write(d / "empty.csv", "");
  write(d / "noheader.csv", "# only a comment\n");
  write(d / "filter_trunc.json", "{\"format\": \"pvdfkit-restore-filter\", \"taps\": 4, \"filters\": {\"h11\": [" +
                                     std::string(40000, '1').insert(0, "0.") + ", ");
  write(d / "filter_deep.json", std::string(100000, '['));
  const std::string filter_head = R"({"format": "pvdfkit-restore-filter", "format_version": 1, "sample_spacing_m": 0.001,
      "taps": 2, "delay_samples": 1, "beta": {}, "filters": {"h12": [0, 0], "h21": [0, 0], "h22": [0, 1], )";
  write(d / "filter_ok.json", filter_head + R"("h11": [1, 0]}})");
  write(d / "filter_huge_tap.json", filter_head + R"("h11": [1e308, 0]}})");
  std::string stream = "t_s,charge_A_C,charge_B_C,charge_C_C\n";
  for (int i = 0; i < 20000; ++i) stream += std::to_string(i * 1e-4) + ",4e-11,2e-11,1.5e-11\n";
  write(d / "stream.csv", stream);
  write(d / "scan.csv", "x_m,m1_V,m2_V\n0,0,0\n0.001,0,0\n0.002,0,0\n0.003,0,0\n");
  // Outputs that must never be replaced: a symbolic link to a file, one to standard output.
  write(d / "target.txt", "the link's target: must stay unchanged\n");
  std::filesystem::create_symlink("target.txt", d / "link.out");
  std::filesystem::create_symlink("/proc/self/fd/1", d / "link_stdout.out");
  std::filesystem::create_directory(d / "realdir");
  std::filesystem::create_directory_symlink("realdir", d / "link_dir");
  // Measured CSVs: a good one (compare, calibrate, rays), duplicate columns, too many rows, huge
  // cells, NUL bytes; fit CSVs with an absurd force.
  const std::string measured_head = "x_m,y_m,force_N,charge_A_C,charge_B_C,charge_C_C\n";
  write(d / "measured.csv", measured_head + "0.002,0.001,1,2e-12,1.8e-11,1.9e-11\n0,0,1,5e-12,5e-12,5e-12\n");
  write(d / "measured_pC.csv", measured_head + "0.002,0.001,1,2,18,19\n");
  write(d / "measured_mN.csv", measured_head + "0.002,0.001,1000000,2e-12,1.8e-11,1.9e-11\n");
  write(d / "measured_dup.csv", "x_m,y_m,force_N,charge_A_C,charge_B_C,charge_C_C,charge_A_C\n0,0,1,1e-12,1e-12,1e-12,2e-12\n");
  std::string many = measured_head;
  for (int i = 0; i < 100001; ++i) many += "0,0,1,5e-12,5e-12,5e-12\n";
  write(d / "measured_many.csv", many);
  write(d / "measured_bigcell.csv", measured_head + "0,0,1,5e-12," + std::string(50000, '7') + ",5e-12\n");
  write(d / "measured_nul.csv", measured_head + bytes("0,0,1,5e-12,5e\x00-12,5e-12\n"));
  write(d / "fit_tiny_force.csv", "x_m,y_m,force_N,deflection_m\n0,0,1e-300,0.003\n0.002,0,1,0.003\n");
  write(d / "fit_dup.csv", "x_m,y_m,force_N,deflection_m,deflection_m\n0,0,1,0.003,0.003\n");
  write(d / "fit_sigma_denormal.csv", "x_m,y_m,force_N,deflection_m,sigma_deflection_m\n0,0,1,0.003,1e-320\n0.002,0,1,0.003,1e-4\n");
  write(d / "fit_ok.csv", "x_m,y_m,force_N,deflection_m\n0,0,1,0.003\n0.002,0,1,0.003\n");
  write(d / "stream_dup.csv", "t_s,charge_A_C,charge_B_C,charge_C_C,charge_B_C\n0,4e-11,2e-11,1.5e-11,2e-11\n");
  // locate --stream: a good row, then one malformed row of each kind (and all of them together).
  const std::string stream_head = "t_s,charge_A_C,charge_B_C,charge_C_C\n";
  const std::string good_row = "0,2.4925e-12,1.87487e-11,1.87487e-11\n";
  write(d / "stream_long_line.csv", stream_head + good_row + std::string(100000, '1') + "\n" + good_row);
  write(d / "stream_inf.csv", stream_head + "1,1e-11,-inf,1e-11\n" + good_row);
  write(d / "stream_fields.csv", stream_head + "1,1e-11\n" + good_row);
  write(d / "stream_nul.csv", stream_head + bytes("1,1e-11,1e-11,1e-\x00" "11\n") + good_row);
  write(d / "stream_big_cell.csv", stream_head + "1,1e-11," + std::string(20000, '7') + ",1e-11\n" + good_row);
  write(d / "stream_rows.csv", stream_head + good_row + "1,nan,1e-11,1e-11\n" + "2,1e-11,inf,1e-11\n" + "3,1e-11\n" +
                                   bytes("4,1e-11,1e-11,1e-\x00" "11\n") + "5,1e-11," + std::string(20000, '7') +
                                   ",1e-11\n" + bytes("6,\x1b[31m,1e-11,1e-11\n") + good_row);
  // Scenes the parser reads but no real film is (docs/scene.md "Physical bounds").
  write(d / "E_tiny.json", seed001_with(R"({"material": {"E1_Pa": 1e-30, "E2_Pa": 1e-30, "G12_Pa": 1e-30}})"));
  write(d / "E2_milli.json", seed001_with(R"({"material": {"E2_Pa": 2.2e-3}})"));
  write(d / "E_huge.json", seed001_with(R"({"material": {"E1_Pa": 1e15}})"));
  write(d / "iso_E_MPa.json", seed001_with(R"({"material": {"E1_Pa": null, "E2_Pa": null, "G12_Pa": null, "nu12": null,
                                                           "E_Pa": 2000, "nu": 0.3}})"));
  write(d / "nu_auxetic.json", seed001_with(R"({"material": {"E1_Pa": null, "E2_Pa": null, "G12_Pa": null, "nu12": null,
                                                            "E_Pa": 2e9, "nu": -0.99}})"));
  write(d / "nu12_auxetic.json", seed001_with(R"({"material": {"nu12": -0.99}})"));
  write(d / "nu12_edge.json", seed001_with(R"({"material": {"nu12": 1.08}})"));
  write(d / "pretension_huge.json", seed001_with(R"({"membrane": {"pretension_N_per_m": -1e9}})"));
  write(d / "pretension_pos.json", seed001_with(R"({"membrane": {"pretension_N_per_m": 1e5}})"));
  write(d / "force_tiny.json", seed001_with(R"({"loads": [{"position_m": [0, 0], "force_N": 1e-300}]})"));
  write(d / "force_zero.json", seed001_with(R"({"loads": [{"position_m": [0, 0], "force_N": 0}]})"));
  write(d / "force_neg.json", seed001_with(R"({"loads": [{"position_m": [0, 0], "force_N": -1}]})"));
  // A 10 mm thick film of diamond-like stiffness: 1 uN deflects it by ~4e-16 m, 1e-14 of its size
  // (below rounding); 1 N is fine (4e-10 m).
  const std::string stiff = R"({"membrane": {"thickness_m": 0.01}, "material": {"E1_Pa": 1e12, "E2_Pa": 1e12, "G12_Pa": 4e11}})";
  write(d / "stiff_thick.json", seed001_with(stiff));
  nlohmann::json stiff_tiny = nlohmann::json::parse(seed001_with(stiff));
  stiff_tiny["loads"] = nlohmann::json::parse(R"([{"position_m": [0, 0], "force_N": 1e-6}])");
  write(d / "stiff_thick_1uN.json", stiff_tiny.dump(1));
  write(d / "probe_as_film.json", seed001_with(R"({"probe": {"radius_m": 0.045}})"));
  write(d / "poisson_pd_edge.json", seed001_with(R"({"material": {"nu12": 1.5}})"));
  write(d / "pressure_huge.json", seed001_with(R"({"loads": [{"type": "pressure", "pressure_Pa": 1e12}]})"));
  // A 10 mm film whose 5 x 3 map (2 mm, x -> -x symmetric) takes about two seconds: the
  // checkpoint rows interrupt it after one row and damage the checkpoint it leaves.
  std::filesystem::copy_file(std::string(PVDF_SOURCE_DIR) + "/tests/mapping/small_film_10mm.json", d / "small_film.json",
                             std::filesystem::copy_options::overwrite_existing);
  // Damages a map checkpoint as a disk, an editor or an attacker would (docs/map-generation.md
  // §7: text header, a `checksum` line, then float64 records). `fix` recomputes the checksum
  // with its own FNV-1a 64, so a NaN charge arrives with a valid checksum.
  write(d / "ckpt_edit.py", R"(import struct, sys
src, dst, mode = sys.argv[1:4]
d = bytearray(open(src, "rb").read())
start = d.index(b"\nchecksum ") + 1
data = d.index(b"\n", start) + 1
charge_A = data + 8 * 6  # record 0: grid index, status, provenance, deflection, model, its error, charges
if mode == "flip":
    d[-5] ^= 1
elif mode == "truncate":
    d = d[:-9]
elif mode == "one-coulomb":
    d[charge_A:charge_A + 8] = struct.pack("d", 1.0)
elif mode == "huge-count":
    d = d.replace(b"\nrecords 3\n", b"\nrecords 10000000000\n")
elif mode == "no-newline":
    d = d[:10] + b"x" * 1000000
elif mode == "format-2":
    d = d.replace(b"pvdfkit-map-checkpoint 3", b"pvdfkit-map-checkpoint 2")
elif mode == "nan-with-checksum":
    d[charge_A:charge_A + 8] = struct.pack("d", float("nan"))
    h = 0xcbf29ce484222325
    for b in bytes(d[:start]) + bytes(d[data:]):
        h = ((h ^ b) * 0x100000001b3) & 0xFFFFFFFFFFFFFFFF
    d = d[:start] + b"checksum %016x\n" % h + d[data:]
open(dst, "wb").write(d)
)");
}

}  // namespace pvdf::test
