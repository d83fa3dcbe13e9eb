#include <glovepose/grid/grid_map.hpp>
#include <glovepose/hand/dofs.hpp>
#include <glovepose/nn/model.hpp>

#include <doctest/doctest.h>

#include <cstdio>
#include <fstream>
#include <random>
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
