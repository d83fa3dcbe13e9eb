#include <glovepose/io/tensor_file.hpp>
#include <glovepose/io/dataset.hpp>

#include <doctest/doctest.h>

#include "test_files.hpp"

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

using namespace glovepose;
using io::Dataset;
using io::DType;
using io::RawTensor;
using io::TensorFile;

namespace {

using glovepose::test::temp_path;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// Two subjects, two sessions each, raw rows with dropped (NaN) entries, labels and the true angles behind them; values of every magnitude.
Dataset make_dataset(std::size_t frames = 12, bool raw = true, bool angles = true, bool truth = true) {
  Dataset d(5, raw ? 7 : 0, "test-5", 59.94);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  for (std::size_t i = 0; i < frames; ++i) {
    for (std::size_t c = 0; c < d.cell_count; ++c)
      d.cells.push_back(std::ldexp(unit(rng), static_cast<int>(c * 7) - 14) + 20.0f * static_cast<float>(c));
    for (std::size_t r = 0; r < d.row_count; ++r)
      d.raw_rows.push_back((i + r) % 5 == 0 ? std::numeric_limits<float>::quiet_NaN() : 100.0f + unit(rng));
    if (angles)
      for (std::size_t k = 0; k < hand::kDofCount; ++k) d.angles.push_back(unit(rng) * 1.5f);
    if (angles && truth)
      for (std::size_t k = 0; k < hand::kDofCount; ++k) d.true_angles.push_back(unit(rng) * 1.5f);
    const auto s = static_cast<std::int32_t>(i / (frames / 4 ? frames / 4 : 1));
    d.subject.push_back(s / 2);
    d.session.push_back(s % 2);
    d.glove.push_back(s % 2 ? 1 : 0);
    d.donning.push_back(s % 2);
    d.kind.push_back(i % 3 == 0 ? io::kKindCalibration : io::kKindRecording);
    d.outlier.push_back(i % 4 == 1 ? 1 : 0);
    d.timestamps.push_back(1e-3 + static_cast<double>(i) / 59.94);
  }
  return d;
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0);
}

void check_equal(const Dataset& a, const Dataset& b) {
  CHECK(a.cell_count == b.cell_count);
  CHECK(a.row_count == b.row_count);
  CHECK(same_bits(a.cells, b.cells));
  CHECK(same_bits(a.raw_rows, b.raw_rows));
  CHECK(same_bits(a.angles, b.angles));
  CHECK(same_bits(a.true_angles, b.true_angles));
  CHECK(a.timestamps == b.timestamps);
  CHECK(a.subject == b.subject);
  CHECK(a.session == b.session);
  CHECK(a.glove == b.glove);
  CHECK(a.donning == b.donning);
  CHECK(a.kind == b.kind);
  CHECK(a.outlier == b.outlier);
  CHECK(a.metadata == b.metadata);
}

using glovepose::test::slurp;

}  // namespace

TEST_CASE("tensor_file: every dtype round-trips byte-exactly (serialize -> parse -> serialize, write -> read)") {
  TensorFile f;
  f.metadata["format"] = "test";
  f.metadata["note"] = "\"quoted\"\n\\";
  f.tensors["f64"] = RawTensor::from<double>({2, 3}, {0.1, -0.0, kNaN, kInf, 5e-324, 1.7976931348623157e308});
  f.tensors["f32"] =
      RawTensor::from<float>({4}, {0.1f, std::numeric_limits<float>::quiet_NaN(), -std::numeric_limits<float>::infinity(), 1e-45f});
  f.tensors["f16"] = RawTensor::from<float>({3}, {0.5f, -65504.0f, 6e-8f}, DType::F16);
  f.tensors["bf16"] = RawTensor::from<float>({3}, {1.0f, -3.0e38f, std::numeric_limits<float>::quiet_NaN()}, DType::BF16);
  f.tensors["i64"] =
      RawTensor::from<std::int64_t>({3}, {std::numeric_limits<std::int64_t>::min(), -1, std::numeric_limits<std::int64_t>::max()});
  f.tensors["i32"] =
      RawTensor::from<std::int32_t>({1, 3}, {std::numeric_limits<std::int32_t>::min(), 0, std::numeric_limits<std::int32_t>::max()});
  f.tensors["u8"] = RawTensor::from<std::uint8_t>({2, 2}, {0, 1, 128, 255});
  f.tensors["scalar"] = RawTensor::from<double>({}, {42.0});
  f.tensors["empty"] = RawTensor::from<float>({0, 3}, {});

  const std::string bytes = f.serialize();
  std::uint64_t header = 0;
  std::memcpy(&header, bytes.data(), 8);
  CHECK((8 + header) % 8 == 0);
  const TensorFile g = TensorFile::parse(bytes);
  CHECK(g.metadata == f.metadata);
  CHECK(g.tensors == f.tensors);
  CHECK(g.serialize() == bytes);
  CHECK(g.tensors.at("i64").file_offset > 8 + header - 1);

  f.write(temp_path("all_dtypes.safetensors"));
  CHECK(slurp(temp_path("all_dtypes.safetensors")) == bytes);
  const TensorFile h = TensorFile::read(temp_path("all_dtypes.safetensors"));
  CHECK(h.tensors == f.tensors);
  CHECK(h.serialize() == bytes);

  // Values come back as stored, little-endian on disk.
  CHECK(g.tensors.at("i64").to<std::int64_t>()[0] == std::numeric_limits<std::int64_t>::min());
  CHECK(g.tensors.at("i32").to<std::int32_t>()[2] == std::numeric_limits<std::int32_t>::max());
  CHECK(g.tensors.at("u8").to<std::uint8_t>()[3] == 255);
  CHECK(g.tensors.at("i32").bytes.substr(8, 4) == std::string("\xff\xff\xff\x7f", 4));
  const std::vector<double> f64 = g.tensors.at("f64").to<double>();
  CHECK(f64[0] == 0.1);
  CHECK(std::signbit(f64[1]));
  CHECK(std::isnan(f64[2]));
  CHECK(f64[3] == kInf);
  CHECK(f64[4] == 5e-324);
  CHECK(g.tensors.at("f16").to<float>() == std::vector<float>{0.5f, -65504.0f, io::f16_to_float(io::float_to_f16(6e-8f))});
  CHECK(std::isnan(g.tensors.at("bf16").to<float>()[2]));
  CHECK(g.tensors.at("scalar").to<double>() == std::vector<double>{42.0});
  CHECK(g.tensors.at("empty").to<float>().empty());
}

TEST_CASE("tensor_file: conversions: floating dtypes freely, integers only when exact") {
  const RawTensor f64 = RawTensor::from<double>({3}, {1.0, 2.5, -3.0});
  CHECK(f64.to<float>() == std::vector<float>{1.0f, 2.5f, -3.0f});
  CHECK(RawTensor::from<double>({2}, {-7.0, 255.0}).to<std::int32_t>() == std::vector<std::int32_t>{-7, 255});
  CHECK(RawTensor::from<std::int32_t>({2}, {-7, 16777216}).to<float>() == std::vector<float>{-7.0f, 16777216.0f});
  CHECK(RawTensor::from<std::int32_t>({2}, {3, 200}, DType::U8).to<std::int64_t>() == std::vector<std::int64_t>{3, 200});
  CHECK(RawTensor::from<std::int32_t>({1}, {2048}, DType::F16).to<std::int32_t>() == std::vector<std::int32_t>{2048});
  CHECK(RawTensor::from<float>({1}, {1.5f}, DType::F64).to<double>() == std::vector<double>{1.5});

  CHECK_THROWS_WITH_AS(f64.to<std::int32_t>(), doctest::Contains("element 1: 2.5 (F64) cannot be stored exactly as I32"), Error);
  CHECK_THROWS_WITH_AS(RawTensor::from<double>({1}, {kNaN}).to<std::int64_t>(), doctest::Contains("element 0: nan (F64)"), Error);
  CHECK_THROWS_WITH_AS(RawTensor::from<std::int64_t>({1}, {(std::int64_t{1} << 53) + 1}).to<double>(),
                       doctest::Contains("9007199254740993 (I64) cannot be stored exactly as F64"), Error);
  CHECK_THROWS_WITH_AS(RawTensor::from<std::int32_t>({1}, {16777217}).to<float>(), doctest::Contains("cannot be stored exactly as F32"),
                       Error);
  CHECK_THROWS_WITH_AS(RawTensor::from<std::int32_t>({2}, {1, 256}, DType::U8),
                       doctest::Contains("element 1: 256 (I32) cannot be stored exactly as U8"), Error);
  CHECK_THROWS_WITH_AS(RawTensor::from<double>({1}, {-1.0}, DType::U8), doctest::Contains("an integer within the range of U8"), Error);
  CHECK_THROWS_WITH_AS(RawTensor::from<std::int32_t>({1}, {2049}, DType::F16),
                       doctest::Contains("2049 (I32) cannot be stored exactly as F16"), Error);
  CHECK_THROWS_WITH_AS(RawTensor::from<std::int64_t>({1}, {std::numeric_limits<std::int64_t>::max()}).to<double>(),
                       doctest::Contains("cannot be stored exactly as F64"), Error);
  CHECK_THROWS_WITH_AS(RawTensor::from<float>({2, 2}, {1.0f}), doctest::Contains("1 values for shape [2, 2], expected 4"), Error);
  RawTensor cut = f64;
  cut.bytes.pop_back();
  CHECK_THROWS_WITH_AS(cut.to<double>(), doctest::Contains("23 bytes for shape [3] of F64, expected 24"), Error);
}

TEST_CASE("tensor_file: structural errors name the tensor, the dtype or the file") {
  TensorFile f;
  f.tensors["a"] = RawTensor::from<float>({2}, {1.0f, 2.0f});
  f.tensors["a"].bytes += "x";
  CHECK_THROWS_WITH_AS(f.serialize(), doctest::Contains("TensorFile: tensor 'a': 9 bytes for shape [2] of F32, expected 8"), Error);
  f.tensors.clear();
  f.tensors["__metadata__"] = RawTensor::from<float>({1}, {1.0f});
  CHECK_THROWS_WITH_AS(f.serialize(), doctest::Contains("'__metadata__' is reserved"), Error);

  std::string header = R"({"a":{"dtype":"BOOL","shape":[2],"data_offsets":[0,2]}})";
  std::string bytes(8, '\0');
  bytes[0] = static_cast<char>(header.size());
  CHECK_THROWS_WITH_AS(TensorFile::parse(bytes + header + "xx"),
                       doctest::Contains("tensor 'a': dtype BOOL, expected one of F64, F32, F16, BF16, I64, I32, U8"), Error);
  CHECK_THROWS_WITH_AS(TensorFile::read(temp_path("does_not_exist.safetensors")), doctest::Contains("tensor file '"), Error);
  CHECK_THROWS_WITH_AS(TensorFile::read(temp_path("does_not_exist.safetensors"), "dataset file"),
                       doctest::Contains("does_not_exist.safetensors': cannot open"), Error);
  std::ofstream(temp_path("short.safetensors"), std::ios::binary) << "abc";
  CHECK_THROWS_WITH_AS(TensorFile::read(temp_path("short.safetensors")), doctest::Contains("file is 3 bytes, expected at least 8"), Error);
}

TEST_CASE("dataset: write and read back exactly, NaN kept in raw_rows, the file holds the documented tensors") {
  const Dataset d = make_dataset();
  REQUIRE_NOTHROW(d.validate());
  d.write(temp_path("roundtrip.dataset"));
  const Dataset e = Dataset::read(temp_path("roundtrip.dataset"));
  check_equal(d, e);
  CHECK(std::isnan(e.raw_rows[0]));
  CHECK(e.glove_layout() == "test-5");
  CHECK(e.frame_rate() == 59.94);

  const TensorFile file = TensorFile::read(temp_path("roundtrip.dataset"));
  const std::pair<const char*, DType> expected[] = {
      {"cells", DType::F32},   {"raw_rows", DType::F32}, {"angles", DType::F32},  {"true_angles", DType::F32},
      {"timestamps", DType::F64}, {"subject", DType::I32}, {"session", DType::I32}, {"glove", DType::I32},
      {"donning", DType::I32}, {"kind", DType::U8},        {"outlier", DType::U8}};
  CHECK(file.tensors.size() == 11);
  for (const auto& entry : expected) {  // no structured binding: clang 14 (C++17) cannot capture one in INFO's lambda
    const char* const name = entry.first;
    const DType dtype = entry.second;
    INFO(name);
    REQUIRE(file.tensors.count(name) == 1);
    CHECK(file.tensors.at(name).dtype == dtype);
    CHECK(file.tensors.at(name).shape[0] == 12);
  }
  CHECK(file.tensors.at("cells").shape == std::vector<std::int64_t>{12, 5});
  CHECK(file.tensors.at("raw_rows").shape == std::vector<std::int64_t>{12, 7});
  CHECK(file.tensors.at("angles").shape == std::vector<std::int64_t>{12, 25});
  CHECK(file.tensors.at("true_angles").shape == std::vector<std::int64_t>{12, 25});
  CHECK(file.metadata.at("format") == "glovepose-dataset");
  CHECK(file.metadata.at("version") == "1");
  CHECK(file.metadata.at("frame_rate") == "59.94");
  CHECK(file.serialize() == slurp(temp_path("roundtrip.dataset")));

  // Without the optional tensors, and with no frames at all.
  const Dataset bare = make_dataset(8, false, false);
  const Dataset bare_back = Dataset::from_tensor_file(TensorFile::parse(bare.to_tensor_file().serialize()));
  check_equal(bare, bare_back);
  CHECK(!bare_back.has_raw_rows());
  CHECK(!bare_back.has_angles());
  CHECK(!bare_back.has_true_angles());
  const Dataset labels_only = make_dataset(8, false, true, false);
  check_equal(labels_only, Dataset::from_tensor_file(TensorFile::parse(labels_only.to_tensor_file().serialize())));
  CHECK(!labels_only.has_true_angles());
  const Dataset none(44, 180, "glauser2019-44", 60.0);
  const Dataset none_back = Dataset::from_tensor_file(TensorFile::parse(none.to_tensor_file().serialize()));
  CHECK(none_back.frames() == 0);
  CHECK(none_back.cell_count == 44);
  CHECK(none_back.row_count == 180);
}

TEST_CASE("dataset: every read error names the tensor and what was expected") {
  const TensorFile good = make_dataset().to_tensor_file();
  REQUIRE_NOTHROW(Dataset::from_tensor_file(good));
  TensorFile f = good;
  SUBCASE("missing tensor") {
    f.tensors.erase("donning");
    CHECK_THROWS_WITH_AS(Dataset::from_tensor_file(f), doctest::Contains("tensor 'donning' is missing, expected I32 [12]"), Error);
    f = good;
    f.tensors.erase("timestamps");
    CHECK_THROWS_WITH_AS(Dataset::from_tensor_file(f), doctest::Contains("tensor 'timestamps' is missing, expected F64 [N]"), Error);
    f = good;
    f.tensors.erase("cells");
    CHECK_THROWS_WITH_AS(Dataset::from_tensor_file(f), doctest::Contains("tensor 'cells' is missing, expected F32 [N, C]"), Error);
  }
  SUBCASE("unknown tensor") {
    f.tensors["pressure"] = RawTensor::from<float>({12}, std::vector<float>(12, 0.0f));
    CHECK_THROWS_WITH_AS(Dataset::from_tensor_file(f), doctest::Contains("unknown tensor 'pressure', expected only cells, raw_rows"),
                         Error);
  }
  SUBCASE("wrong dtype") {
    f.tensors["subject"] = RawTensor::from<std::int32_t>({12}, std::vector<std::int32_t>(12, 0), DType::I64);
    CHECK_THROWS_WITH_AS(Dataset::from_tensor_file(f), doctest::Contains("tensor 'subject' has dtype I64, expected I32"), Error);
    f = good;
    f.tensors["timestamps"] = RawTensor::from<double>({12}, good.tensors.at("timestamps").to<double>(), DType::F32);
    CHECK_THROWS_WITH_AS(Dataset::from_tensor_file(f), doctest::Contains("tensor 'timestamps' has dtype F32, expected F64"), Error);
    f = good;
    f.tensors["raw_rows"].dtype = DType::I32;
    CHECK_THROWS_WITH_AS(Dataset::from_tensor_file(f), doctest::Contains("tensor 'raw_rows' has dtype I32, expected F32"), Error);
  }
  SUBCASE("wrong shape") {
    f.tensors["angles"] = RawTensor::from<float>({12, 24}, std::vector<float>(12 * 24, 0.0f));
    CHECK_THROWS_WITH_AS(Dataset::from_tensor_file(f),
                         doctest::Contains("tensor 'angles' has shape [12, 24], expected [12, 25] (frames x 25 DoFs)"), Error);
    f = good;
    f.tensors["kind"] = RawTensor::from<std::uint8_t>({11}, std::vector<std::uint8_t>(11, 0));
    CHECK_THROWS_WITH_AS(Dataset::from_tensor_file(f), doctest::Contains("tensor 'kind' has shape [11], expected [12] (frames)"), Error);
    f = good;
    f.tensors["cells"] = RawTensor::from<float>({60}, std::vector<float>(60, 0.0f));
    CHECK_THROWS_WITH_AS(Dataset::from_tensor_file(f), doctest::Contains("tensor 'cells' has shape [60], expected [12, C] with C >= 1"),
                         Error);
    f = good;
    f.tensors["timestamps"] = RawTensor::from<double>({3, 4}, good.tensors.at("timestamps").to<double>());
    CHECK_THROWS_WITH_AS(Dataset::from_tensor_file(f), doctest::Contains("tensor 'timestamps' has shape [3, 4], expected [N]"), Error);
  }
  SUBCASE("not a dataset, or another version") {
    f.metadata["format"] = "glovepose-model";
    CHECK_THROWS_WITH_AS(Dataset::from_tensor_file(f),
                         doctest::Contains("metadata 'format' is 'glovepose-model', expected 'glovepose-dataset'"), Error);
    f = good;
    f.metadata["version"] = "2";
    CHECK_THROWS_WITH_AS(Dataset::from_tensor_file(f), doctest::Contains("metadata 'version' is '2', expected '1'"), Error);
    f = good;
    f.metadata.erase("version");
    CHECK_THROWS_WITH_AS(Dataset::from_tensor_file(f), doctest::Contains("metadata 'version' is missing, expected '1'"), Error);
  }
  SUBCASE("contents validate() refuses, and the path in the message") {
    std::vector<float> cells = good.tensors.at("cells").to<float>();
    cells[7] = std::numeric_limits<float>::infinity();
    f.tensors["cells"] = RawTensor::from<float>({12, 5}, cells);
    f.write(temp_path("bad.dataset"));
    CHECK_THROWS_WITH_AS(Dataset::read(temp_path("bad.dataset")),
                         doctest::Contains("bad.dataset': Dataset: tensor 'cells': frame 1, cell 2 is inf, expected a finite capacitance"),
                         Error);
  }
}

TEST_CASE("dataset: validate names the tensor, the frame and what was expected") {
  const Dataset good = make_dataset();
  Dataset d = good;
  d.cells.pop_back();
  CHECK_THROWS_WITH_AS(d.validate(), doctest::Contains("tensor 'cells' holds 59 values, expected 12 frames x 5 (cell_count) = 60"), Error);
  d = good;
  d.outlier.push_back(0);
  CHECK_THROWS_WITH_AS(d.validate(), doctest::Contains("tensor 'outlier' holds 13 values, expected one per frame: 12"), Error);
  d = good;
  d.angles.resize(12 * 24);
  CHECK_THROWS_WITH_AS(d.validate(), doctest::Contains("tensor 'angles' holds 288 values, expected 12 frames x 25 (25 DoFs) = 300"), Error);
  d = good;
  d.row_count = 0;
  CHECK_THROWS_WITH_AS(d.validate(), doctest::Contains("tensor 'raw_rows' holds 84 values, expected 12 frames x 0 (row_count) = 0"), Error);
  d = good;
  d.angles[25 * 3 + 5] = std::numeric_limits<float>::quiet_NaN();
  d.kind[3] = io::kKindRecording;
  CHECK_THROWS_WITH_AS(d.validate(),
                       doctest::Contains("tensor 'angles': frame 3, DoF 'index_base_flexion' is nan, expected a finite angle"), Error);
  d.kind[3] = io::kKindCalibration;  // a calibration frame may carry no reference (a sensors-only calibration take)
  d.validate();
  d = good;
  d.true_angles.pop_back();
  CHECK_THROWS_WITH_AS(d.validate(), doctest::Contains("tensor 'true_angles' holds 299 values, expected 12 frames x 25 (25 DoFs) = 300"),
                       Error);
  d = good;
  d.true_angles[25 * 2 + 1] = std::numeric_limits<float>::infinity();
  CHECK_THROWS_WITH_AS(d.validate(),
                       doctest::Contains("tensor 'true_angles': frame 2, DoF 'thumb_base_flexion' is inf, expected a finite angle (radians)"),
                       Error);
  d = good;
  d.angles.clear();
  CHECK_THROWS_WITH_AS(d.validate(), doctest::Contains("tensor 'true_angles' without 'angles', expected the labels beside"), Error);
  d = good;
  d.raw_rows[8] = -std::numeric_limits<float>::infinity();
  CHECK_THROWS_WITH_AS(
      d.validate(), doctest::Contains("tensor 'raw_rows': frame 1, row 1 is infinite, expected a finite capacitance (pF) or NaN"), Error);
  d = good;
  d.timestamps[2] = d.timestamps[1];
  CHECK_THROWS_WITH_AS(d.validate(), doctest::Contains("tensor 'timestamps': frame 2 is 0.017683350016683353 s, not after frame 1"), Error);
  CHECK_THROWS_WITH_AS(d.validate(),
                       doctest::Contains("of the same run (subject 0, glove 0, session 0, kind 0), expected strictly increasing times"),
                       Error);
  d = good;
  d.timestamps[3] = 0.0;  // frame 3 starts a new run (session 1): allowed
  CHECK_NOTHROW(d.validate());
  d.timestamps[4] = kInf;
  CHECK_THROWS_WITH_AS(d.validate(), doctest::Contains("tensor 'timestamps': frame 4 is inf, expected finite seconds"), Error);
  d = good;
  d.kind[5] = 3;
  CHECK_THROWS_WITH_AS(d.validate(), doctest::Contains("tensor 'kind': frame 5 is 3, expected 0 (recording), 1 (calibration) or 2 (removal)"),
                       Error);
  d = good;
  d.outlier[5] = 7;
  CHECK_THROWS_WITH_AS(d.validate(), doctest::Contains("tensor 'outlier': frame 5 is 7, expected 0 or 1"), Error);
  d = good;
  d.donning[0] = -1;
  CHECK_THROWS_WITH_AS(d.validate(), doctest::Contains("tensor 'donning': frame 0 is -1, expected an id >= 0"), Error);
  d = good;
  d.metadata["frame_rate"] = "fast";
  CHECK_THROWS_WITH_AS(d.validate(), doctest::Contains("metadata 'frame_rate' is 'fast', expected a positive number"), Error);
  d = good;
  d.metadata.erase("glove_layout");
  CHECK_THROWS_WITH_AS(d.validate(), doctest::Contains("metadata 'glove_layout' is missing"), Error);
  d = good;
  d.cell_count = 0;
  d.cells.clear();
  CHECK_THROWS_WITH_AS(d.validate(), doctest::Contains("cell_count is 0, expected at least 1"), Error);
  CHECK_THROWS_WITH_AS(Dataset().validate(), doctest::Contains("metadata 'glove_layout' is missing"), Error);
}

TEST_CASE("dataset: append and select keep every array in step") {
  const Dataset a = make_dataset(12);
  Dataset all;
  all.append(a);
  all.append(a.select([](std::size_t i) { return i >= 6; }));
  CHECK(all.frames() == 18);
  const Dataset tail = all.select([](std::size_t i) { return i >= 12; });
  const Dataset expected = a.select([](std::size_t i) { return i >= 6; });
  check_equal(tail, expected);
  CHECK(tail.frames() == 6);
  CHECK(tail.raw_rows.size() == 6 * 7);
  const Dataset odd = a.select([](std::size_t i) { return i % 2 == 1; });
  REQUIRE(odd.frames() == 6);
  CHECK(odd.timestamps[2] == a.timestamps[5]);
  CHECK(odd.cells[2 * 5 + 4] == a.cells[5 * 5 + 4]);
  CHECK(odd.angles[2 * 25 + 24] == a.angles[5 * 25 + 24]);
  CHECK(odd.true_angles[2 * 25 + 3] == a.true_angles[5 * 25 + 3]);
  CHECK(odd.outlier[2] == a.outlier[5]);
  CHECK_NOTHROW(odd.validate());
  CHECK(a.select([](std::size_t) { return false; }).frames() == 0);

  Dataset other = make_dataset(4, false);
  CHECK_THROWS_WITH_AS(all.append(other), doctest::Contains("the appended dataset has row_count 0, expected 7 as this one"), Error);
  other = make_dataset(4, true, false);
  CHECK_THROWS_WITH_AS(all.append(other), doctest::Contains("has angles absent, expected present"), Error);
  other = make_dataset(4, true, true, false);
  CHECK_THROWS_WITH_AS(all.append(other), doctest::Contains("has true_angles absent, expected present"), Error);
  other = make_dataset(4);
  other.metadata["glove_layout"] = "glauser2019-44";
  CHECK_THROWS_WITH_AS(all.append(other), doctest::Contains("metadata 'glove_layout' 'glauser2019-44', expected 'test-5'"), Error);
}

TEST_CASE("dataset: CSV export then import gives the same cells, angles and timestamps") {
  for (bool angles : {true, false}) {
    INFO("angles " << angles);
    const Dataset d = make_dataset(12, true, angles);
    std::stringstream csv;
    d.write_csv(csv);
    const std::string text = csv.str();
    const std::string first_line = text.substr(0, text.find('\n'));
    CHECK(first_line.rfind("subject,session,timestamp,cell_0,cell_1,cell_2,cell_3,cell_4", 0) == 0);
    CHECK((first_line.find(",thumb_base_abduction,thumb_base_flexion,") != std::string::npos) == angles);
    // CSV carries subject, session, timestamps, cells and angles; the importer fills the rest.
    Dataset expected = d;
    expected.row_count = 0;
    expected.raw_rows.clear();
    expected.glove.assign(12, 0);
    expected.donning = d.session;
    expected.kind.assign(12, io::kKindRecording);
    expected.outlier.assign(12, 0);
    expected.true_angles.clear();  // not part of the CSV
    check_equal(Dataset::read_csv(csv, "test-5", 59.94), expected);
  }
  const Dataset d = make_dataset();
  d.write_csv(temp_path("roundtrip.csv"));
  CHECK(Dataset::read_csv(temp_path("roundtrip.csv"), "test-5", 59.94).timestamps == d.timestamps);
  std::istringstream crlf("subject,session,timestamp,cell_0\r\n 1 , 2 , 0.5 , 7.25\r\n\r\n1,2,0.75,+8\r\n");
  const Dataset w = Dataset::read_csv(crlf, "g", 60.0);
  CHECK(w.cells == std::vector<float>{7.25f, 8.0f});
  CHECK(w.subject == std::vector<std::int32_t>{1, 1});
}

TEST_CASE("dataset: each CSV import error names the line, the column and what was expected") {
  const auto import = [](const std::string& text) {
    std::istringstream in(text);
    return Dataset::read_csv(in, "g", 60.0);
  };
  std::string header = "subject,session,timestamp";
  for (int c = 0; c < 44; ++c) header += ",cell_" + std::to_string(c);
  for (const hand::Dof& dof : hand::kDofs) header += std::string(",") + dof.name;
  const auto row = [](const std::string& subject_session, double t, const std::string& cell3 = "1") {
    std::string r = subject_session + "," + io::number_text(t);
    for (int c = 0; c < 44; ++c) r += "," + (c == 3 ? cell3 : std::string("20.5"));
    for (int d = 0; d < 25; ++d) r += ",0.25";
    return r + "\n";
  };
  std::string good = header + "\n";
  for (int i = 0; i < 5; ++i) good += row("1,0", 0.1 * i);
  REQUIRE(import(good).frames() == 5);
  REQUIRE(import(good).cell_count == 44);

  CHECK_THROWS_WITH_AS(import(good + "1,0,0.6,1,2,3,4,5,6,7,8,9\n"), doctest::Contains("line 7: 12 columns, expected 72"), Error);
  CHECK_THROWS_WITH_AS(import(good + row("1,0", 0.6, "abc")), doctest::Contains("line 7, column 'cell_3': 'abc' is not a number"), Error);
  CHECK_THROWS_WITH_AS(import(good + row("1,0", 0.6, "1.5x")), doctest::Contains("line 7, column 'cell_3': '1.5x' is not a number"), Error);
  CHECK_THROWS_WITH_AS(import(good + row("1,0", 0.6, "nan")), doctest::Contains("line 7, column 'cell_3': 'nan' is not a finite number"),
                       Error);
  CHECK_THROWS_WITH_AS(import(good + row("1,0", 0.6, "")), doctest::Contains("line 7, column 'cell_3': '' is not a number"), Error);
  CHECK_THROWS_WITH_AS(import(good + row("x,0", 0.6)), doctest::Contains("line 7, column 'subject': 'x' is not a non-negative integer"),
                       Error);
  CHECK_THROWS_WITH_AS(import(good + row("1,-2", 0.6)), doctest::Contains("line 7, column 'session': '-2' is not a non-negative integer"),
                       Error);
  CHECK_THROWS_WITH_AS(import(good + row("2,0", 0.0) + row("1,0", 0.5) + row("1,0", 0.5)),
                       doctest::Contains("line 9: timestamp 0.5 is not after the previous 0.5 of subject 1 session 0"), Error);
  CHECK_THROWS_WITH_AS(import(good + row("1,0", 0.3)), doctest::Contains("line 7: timestamp 0.3 is not after the previous 0.4"), Error);
  CHECK_NOTHROW(import(good + row("1,1", 0.0) + row("2,0", 0.0)));  // other sessions and subjects restart the clock
  CHECK_NOTHROW(import(good + row("1,1", 0.0) + row("1,0", 0.0)));  // a new run of subject 1 session 0 (e.g. another glove)
  CHECK_THROWS_WITH_AS(import(""), doctest::Contains("line 1: no header, expected subject,session,timestamp,cell_0"), Error);
  CHECK_THROWS_WITH_AS(import("subject,session,time,cell_0\n"),
                       doctest::Contains("line 1, column 3: unknown column 'time', expected 'timestamp'"), Error);
  CHECK_THROWS_WITH_AS(import("subject,session,timestamp,cell_1\n"),
                       doctest::Contains("line 1, column 4: unknown column 'cell_1', expected 'cell_0'"), Error);
  CHECK_THROWS_WITH_AS(import("subject,session,timestamp\n"),
                       doctest::Contains("line 1: 3 columns, expected subject,session,timestamp,cell_0"), Error);
  CHECK_THROWS_WITH_AS(import("subject,session,timestamp,cell_0,cell_2\n"),
                       doctest::Contains("line 1, column 5: unknown column 'cell_2', expected 'cell_1' or a DoF name"), Error);
  CHECK_THROWS_WITH_AS(
      import("subject,session,timestamp,cell_0,thumb_base_flexion,thumb_base_abduction\n"),
      doctest::Contains("line 1, column 6: unknown column 'thumb_base_abduction', expected a DoF after 'thumb_base_flexion' "
                        "(the DoFs in the order of hand::kDofs)"),
      Error);
  CHECK_THROWS_WITH_AS(import(header + ",extra\n"), doctest::Contains("unknown column 'extra', expected a DoF after '"), Error);
  {
    // A subset of the DoFs: the others are not labelled (NaN, metadata), and write_csv writes the same subset.
    const Dataset part = import("subject,session,timestamp,cell_0,thumb_base_abduction,index_base_flexion\n1,0,0.5,2.5,0.25,-0.5\n");
    hand::DofSet expected{};
    expected[hand::dof_from_name("thumb_base_abduction")] = expected[hand::dof_from_name("index_base_flexion")] = true;
    CHECK(part.labelled_dofs() == expected);
    CHECK(part.metadata.at("labelled_dofs") == "thumb_base_abduction,index_base_flexion");
    REQUIRE(part.angles.size() == hand::kDofCount);
    for (std::size_t d = 0; d < hand::kDofCount; ++d) {
      CAPTURE(d);
      if (expected[d])
        CHECK(part.angles[d] == (d == 0 ? 0.25f : -0.5f));
      else
        CHECK(std::isnan(part.angles[d]));
    }
    std::ostringstream written;
    part.write_csv(written);
    CHECK(written.str() == "subject,session,timestamp,cell_0,thumb_base_abduction,index_base_flexion\n1,0,0.5,2.5,0.25,-0.5\n");
    Dataset broken = part;
    broken.angles[1] = 0.0f;  // a DoF not labelled with a value
    CHECK_THROWS_WITH_AS(broken.validate(), doctest::Contains("DoF 'thumb_base_flexion' is 0, expected NaN (the DoF is not labelled"),
                         Error);
    broken = part;
    broken.angles[0] = NAN;
    CHECK_THROWS_WITH_AS(broken.validate(), doctest::Contains("DoF 'thumb_base_abduction' is nan, expected a finite angle"), Error);
    // No rows: no angles, so nothing is "not labelled" (found by csv_import_fuzz: the write_csv of
    // such a dataset read back with other metadata).
    const Dataset empty = import("subject,session,timestamp,cell_0,ring_base_twist\n");
    CHECK(empty.labelled_dofs() == hand::all_dofs());
    CHECK(empty.metadata.count("labelled_dofs") == 0);
    Dataset all = part;
    all.set_labelled_dofs(hand::all_dofs());
    std::fill(all.angles.begin(), all.angles.end(), 0.0f);
    all.validate();
    CHECK_THROWS_WITH_AS(all.append(part), doctest::Contains("metadata 'labelled_dofs'"), Error);
  }
  CHECK_THROWS_WITH_AS(Dataset::read_csv(temp_path("missing.csv"), "g", 60.0), doctest::Contains("missing.csv': cannot open"), Error);
  std::ofstream(temp_path("bad.csv")) << good << row("1,0", 0.6, "abc");
  CHECK_THROWS_WITH_AS(Dataset::read_csv(temp_path("bad.csv"), "g", 60.0), doctest::Contains("bad.csv': line 7, column 'cell_3'"), Error);
}

TEST_CASE("dataset: a dataset file parses with plain json + numpy, as safetensors reads it") {
  const std::string python = "/usr/bin/python3";
  if (std::system((python + " -c 'import numpy' > /dev/null 2>&1").c_str()) != 0) {
    MESSAGE("NOT CHECKED: /usr/bin/python3 with numpy is not installed");
    return;
  }
  const Dataset d = make_dataset();
  d.write(temp_path("python.dataset"));
  const std::string cmd = python + " " + GLOVEPOSE_SOURCE_DIR + "/tests/python/check_dataset_file.py " + temp_path("python.dataset");
  CHECK(std::system(cmd.c_str()) == 0);
}

TEST_CASE("dataset: first_session_frame is the first frame after the leading calibration frames") {
  Dataset d = make_dataset(12);
  // make_dataset marks every third frame as calibration: frame 0 only leads.
  CHECK(d.first_session_frame() == 1);
  for (std::size_t i = 0; i < d.frames(); ++i) d.kind[i] = i < 5 || i == 8 ? io::kKindCalibration : io::kKindRecording;
  CHECK(d.first_session_frame() == 5);  // the later calibration frame 8 does not count
  for (auto& k : d.kind) k = io::kKindRecording;
  CHECK(d.first_session_frame() == 0);
  for (auto& k : d.kind) k = io::kKindCalibration;
  CHECK(d.first_session_frame() == d.frames());
  CHECK(Dataset(5, 0, "empty", 60.0).first_session_frame() == 0);
}
