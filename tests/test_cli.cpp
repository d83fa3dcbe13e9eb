#include <glovepose/grid/grid_map.hpp>
#include <glovepose/hand/dofs.hpp>
#include <glovepose/nn/model.hpp>
#include <glovepose/train/dataset.hpp>

#include <doctest/doctest.h>

#include <cstdio>
#include <fstream>
#include <iterator>
#include <random>
#include <set>
#include <tuple>
#include <sstream>

using namespace glovepose;

namespace {
struct Run {
  int status;
  std::string out;
};
Run run(const std::string& args) {
  const std::string cmd = std::string(GLOVEPOSE_CLI) + " " + args + " 2>&1";
  FILE* pipe = popen(cmd.c_str(), "r");
  REQUIRE(pipe);
  std::string out;
  char buf[4096];
  while (std::fgets(buf, sizeof buf, pipe)) out += buf;
  const int status = pclose(pipe);
  return {WEXITSTATUS(status), out};
}
const std::string kModel = std::string(GLOVEPOSE_SOURCE_DIR) + "/tests/fixtures/unet_w4.safetensors";
std::string temp(const std::string& name) { return std::string(GLOVEPOSE_TEST_TMP_DIR) + "/" + name; }
}  // namespace

TEST_CASE("cli: glovepose predict gives the library's angles for rows of 44 calibrated cells") {
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<std::vector<double>> rows(5, std::vector<double>(44));
  std::ofstream csv(temp("cells.csv"));
  csv << "# a comment line\n";
  for (auto& row : rows) {
    for (std::size_t c = 0; c < 44; ++c) {
      row[c] = std::round(u(rng) * 1e6) / 1e6;
      csv << (c ? "," : "") << row[c];
    }
    csv << "\n";
  }
  csv.close();
  const Run r = run("predict --model " + kModel + " --in " + temp("cells.csv"));
  REQUIRE(r.status == 0);
  std::istringstream lines(r.out);
  std::string line;
  REQUIRE(std::getline(lines, line));
  CHECK(line.rfind("thumb_base_abduction,thumb_base_flexion,", 0) == 0);

  const auto model = nn::Model<>::load(kModel);
  const grid::GridMap map = grid::GridMap::glauser2019();
  hand::Angles lo{}, hi{};
  for (std::size_t d = 0; d < 25; ++d) {
    lo[d] = model.info.joint_limits_min[d];
    hi[d] = model.info.joint_limits_max[d];
  }
  const hand::JointLimits limits(lo, hi);
  auto ws = model.unet.make_workspace();
  for (const auto& row : rows) {
    REQUIRE(std::getline(lines, line));
    std::array<float, grid::kStretchValues> maps{};
    std::array<float, grid::kMapSlots> pose{};
    REQUIRE(map.to_stretch_maps(row.data(), maps) == Status::Ok);
    REQUIRE(model.unet.forward(maps, pose, ws) == Status::Ok);
    hand::Angles normalized{};
    map.from_pose_map(pose, normalized);
    const hand::Angles expected = limits.denormalize(normalized);
    std::istringstream fields(line);
    std::string field;
    for (std::size_t d = 0; d < 25; ++d) {
      REQUIRE(std::getline(fields, field, ','));
      // The CLI is built for this machine; the baseline suite computes with SSE2: a different
      // summation order, so float rounding, not plumbing, separates them.
      CHECK(std::stod(field) == doctest::Approx(expected[d]).epsilon(1e-5));
    }
  }
  CHECK(!std::getline(lines, line));
}

TEST_CASE("cli: bad input and bad models are refused with the line, column or file named") {
  std::ofstream(temp("short.csv")) << "0.1,0.2,0.3\n";
  Run r = run("predict --model " + kModel + " --in " + temp("short.csv"));
  CHECK(r.status == 2);
  CHECK(r.out.find("line 1: 3 values, expected 44") != std::string::npos);
  std::string bad;
  for (int c = 0; c < 44; ++c) bad += (c ? "," : "") + std::string(c == 7 ? "abc" : "0.5");
  std::ofstream(temp("text.csv")) << bad << "\n";
  r = run("predict --model " + kModel + " --in " + temp("text.csv"));
  CHECK(r.status == 2);
  CHECK(r.out.find("line 1, column 8: 'abc' is not a finite number") != std::string::npos);
  r = run("predict --model " + temp("missing.safetensors"));
  CHECK(r.status == 2);
  CHECK(r.out.find("cannot open") != std::string::npos);
  r = run("predict");
  CHECK(r.status == 2);
  CHECK(r.out.find("--model FILE is required") != std::string::npos);
  r = run("info --model " + kModel);
  CHECK(r.status == 0);
  CHECK(r.out.find("width: 4") != std::string::npos);
}

namespace {
std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
}
}  // namespace

TEST_CASE("cli: glovepose simulate writes the protocol as one dataset file, byte-identical for a seed") {
  const std::string small = "--subjects 2 --sessions 4 --minutes 0.05 --gloves 2 --calibration-seconds 1 --raw-rows";
  const Run a = run("simulate --seed 3 " + small + " --threads 1 --out " + temp("sim_a.safetensors") + " --csv " + temp("sim_a.csv"));
  INFO(a.out);
  REQUIRE(a.status == 0);
  const Run b = run("simulate --seed 3 " + small + " --threads 2 --out " + temp("sim_b.safetensors"));
  REQUIRE(b.status == 0);
  const Run c = run("simulate --seed 4 " + small + " --out " + temp("sim_c.safetensors"));
  REQUIRE(c.status == 0);
  const std::string bytes = slurp(temp("sim_a.safetensors"));
  CHECK(bytes.size() > 100000);
  CHECK(bytes == slurp(temp("sim_b.safetensors")));  // same seed, other thread count: same bytes
  CHECK(bytes != slurp(temp("sim_c.safetensors")));

  const train::Dataset d = train::Dataset::read(temp("sim_a.safetensors"));
  // Per subject: 4 sessions with glove 0 and 2 with glove 1, 3 s each at 60 Hz, each after a 1 s
  // calibration sequence.
  CHECK(d.frames() == 2u * 6u * (180u + 60u));
  CHECK(d.cell_count == 44u);
  CHECK(d.row_count == 180u);
  CHECK(d.glove_layout() == "glauser2019-44");
  CHECK(d.metadata.at("seed") == "3");
  std::set<std::tuple<int, int, int, int>> sessions;  // subject, glove, session, donning
  for (std::size_t f = 0; f < d.frames(); ++f)
    if (d.kind[f] == train::kKindRecording) sessions.insert({d.subject[f], d.glove[f], d.session[f], d.donning[f]});
  CHECK(sessions.count({0, 0, 2, 0}) == 1);  // the glove kept on for sessions 0..2
  CHECK(sessions.count({0, 0, 3, 1}) == 1);  // then taken off and on
  CHECK(sessions.count({1, 1, 1, 1}) == 1);  // glove II, a fresh donning per session
  // The CSV export holds the same frames.
  const train::Dataset from_csv = train::Dataset::read_csv(temp("sim_a.csv"), d.glove_layout(), 60.0);
  CHECK(from_csv.frames() == d.frames());
  CHECK(from_csv.cells == d.cells);

  const Run bad = run("simulate --minutes 0 --out " + temp("sim_bad.safetensors"));
  CHECK(bad.status == 2);
  CHECK(bad.out.find("--minutes") != std::string::npos);
  CHECK(run("simulate --subjects x --out y").status == 2);
}

TEST_CASE("cli: glovepose simulate --report prints every section of the realism report") {
  const Run r = run("simulate --report --seed 2 --subjects 3 --sessions 2 --minutes 0.3");
  INFO(r.out);
  REQUIRE(r.status == 0);
  for (const char* part : {"Per-cell signal", "cell 43 (index distal, across", "Per-DoF coverage", "pinky_base_twist", "Re-donning vs pose change",
                           "Oldest reading behind each frame", "Outlier frames", "leave-one-subject-out"})
    CHECK(r.out.find(part) != std::string::npos);
}
