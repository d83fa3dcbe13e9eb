#include <glovepose/model/model_info.hpp>
#include <glovepose/grid/glove_description.hpp>
#include <glovepose/hand/dofs.hpp>
#include <glovepose/nn/weights.hpp>

#include <doctest/doctest.h>

#include <cstring>
#include <iterator>
#include <limits>

#include "unet_reference.hpp"

using namespace glovepose;
using namespace glovepose::nn;

namespace {
// A file from a literal header and data bytes.
std::string make_file(const std::string& header, const std::string& data) {
  std::string out(8, '\0');
  for (int i = 0; i < 8; ++i) out[static_cast<std::size_t>(i)] = static_cast<char>((header.size() >> (8 * i)) & 0xff);
  return out + header + data;
}
std::string floats(std::initializer_list<float> values) {
  std::string out;
  for (float v : values) out.append(reinterpret_cast<const char*>(&v), 4);  // the test machine is little-endian
  return out;
}
WeightFile small_file() {
  WeightFile f;
  f.tensors["a"] = {{2, 2}, {1.0f, -2.5f, 3.25f, 1e-7f}};
  f.tensors["b.bias"] = {{3}, {0.5f, 0.25f, -0.125f}};
  f.metadata["format"] = "test \"quoted\"\n";
  return f;
}
}  // namespace

TEST_CASE("weights: write and read back exactly, the header is padded so data starts 8-byte aligned") {
  const WeightFile f = small_file();
  const std::string bytes = f.serialize();
  std::uint64_t n = 0;
  std::memcpy(&n, bytes.data(), 8);
  CHECK((8 + n) % 8 == 0);
  const WeightFile g = WeightFile::parse(bytes);
  CHECK(g.metadata == f.metadata);
  REQUIRE(g.tensors.size() == 2);
  CHECK(g.tensors.at("a").shape == f.tensors.at("a").shape);
  CHECK(g.tensors.at("a").values == f.tensors.at("a").values);
  CHECK(g.tensors.at("b.bias").values == f.tensors.at("b.bias").values);
}

TEST_CASE("weights: F16 and BF16 files are accepted and widened") {
  const WeightFile f = small_file();
  const WeightFile h = WeightFile::parse(f.serialize(DType::F16));
  const WeightFile b = WeightFile::parse(f.serialize(DType::BF16));
  for (std::size_t i = 0; i < 4; ++i) {
    const float v = f.tensors.at("a").values[i];
    CHECK(h.tensors.at("a").values[i] == io::f16_to_float(io::float_to_f16(v)));
    CHECK(b.tensors.at("a").values[i] == io::bf16_to_float(io::float_to_bf16(v)));
  }
  CHECK(h.tensors.at("a").values[1] == -2.5f);  // exactly representable
  CHECK_THROWS_WITH_AS(f.serialize(DType::I32), doctest::Contains("WeightFile: dtype I32, expected F32, F16 or BF16"), Error);
}

TEST_CASE("weights: every malformed file is an Error naming the tensor or byte and what was expected") {
  const std::string ok_a = R"("a":{"dtype":"F32","shape":[2],"data_offsets":[0,8]})";
  const std::string data = floats({1.0f, 2.0f});
  REQUIRE_NOTHROW(WeightFile::parse(make_file("{" + ok_a + "}", data)));

  SUBCASE("too short for a header length") {
    CHECK_THROWS_WITH_AS(WeightFile::parse("abc"), doctest::Contains("expected at least 8"), Error);
  }
  SUBCASE("header length beyond the file") {
    std::string bytes = make_file("{" + ok_a + "}", data);
    bytes[5] = 1;  // 2^40 + ...
    CHECK_THROWS_WITH_AS(WeightFile::parse(bytes), doctest::Contains("byte 0: header length"), Error);
  }
  SUBCASE("header length within the limit but beyond the file") {
    std::string bytes = make_file("{" + ok_a + "}", data);
    bytes[0] = static_cast<char>(static_cast<unsigned char>(bytes[0]) + 100);
    const std::string expected = "(the file has " + std::to_string(bytes.size()) + " bytes)";
    CHECK_THROWS_WITH_AS(WeightFile::parse(bytes), doctest::Contains(expected.c_str()), Error);
  }
  SUBCASE("JSON that safetensors refuses") {
    CHECK_THROWS_WITH_AS(WeightFile::parse(make_file(" {" + ok_a + "}", data)), doctest::Contains("does not start with '{'"), Error);
    CHECK_THROWS_WITH_AS(WeightFile::parse(make_file(R"({"a":{"dtype":"F32","shape":[02],"data_offsets":[0,8]}})", data)),
                         doctest::Contains("JSON header: byte 38: syntax error"), Error);  // the '2' of "02"
    CHECK_THROWS_WITH_AS(WeightFile::parse(make_file(R"({"a":{"dtype":"F32","shape":[2],"data_offsets":[0,8],"x":1}})", data)),
                         doctest::Contains("tensor 'a': unexpected key 'x'"), Error);
    CHECK_THROWS_WITH_AS(
        WeightFile::parse(make_file(R"({"a":{"dtype":"F32","shape":[123456789012345678901],"data_offsets":[0,8]}})", data)),
        doctest::Contains("is not a non-negative integer"), Error);
    std::string deep(70, '[');
    CHECK_THROWS_WITH_AS(WeightFile::parse(make_file(R"({"a":)" + deep, "")), doctest::Contains("nesting deeper than 64"), Error);
  }
  SUBCASE("header length too small") {
    std::string bytes = make_file("{" + ok_a + "}", data);
    for (int i = 0; i < 8; ++i) bytes[static_cast<std::size_t>(i)] = 0;
    bytes[0] = 1;
    CHECK_THROWS_WITH_AS(WeightFile::parse(bytes), doctest::Contains("header length 1, expected 2.."), Error);
  }
  SUBCASE("header not JSON") {
    CHECK_THROWS_WITH_AS(WeightFile::parse(make_file("{\"a\": xyz}", data)), doctest::Contains("JSON header: byte 14"), Error);
    CHECK_THROWS_WITH_AS(WeightFile::parse(make_file("[1, 2]  ", "")), doctest::Contains("expected a JSON object"), Error);
    CHECK_THROWS_WITH_AS(WeightFile::parse(make_file("{\"a\":1,\"a\":2}", "")), doctest::Contains("duplicate key 'a'"), Error);
  }
  SUBCASE("truncated data") {
    CHECK_THROWS_WITH_AS(WeightFile::parse(make_file("{" + ok_a + "}", data.substr(0, 6))),
                         doctest::Contains("tensor 'a': data ends at data byte 8 (file byte"), Error);
  }
  SUBCASE("wrong dtype") {
    CHECK_THROWS_WITH_AS(WeightFile::parse(make_file(R"({"a":{"dtype":"I32","shape":[2],"data_offsets":[0,8]}})", data)),
                         doctest::Contains("tensor 'a': dtype I32, expected F32, F16 or BF16"), Error);
  }
  SUBCASE("size of the data does not match the shape") {
    CHECK_THROWS_WITH_AS(WeightFile::parse(make_file(R"({"a":{"dtype":"F32","shape":[3],"data_offsets":[0,8]}})", data)),
                         doctest::Contains("tensor 'a': 8 data bytes for shape [3] of F32, expected 12"), Error);
  }
  SUBCASE("bad shape and offsets") {
    CHECK_THROWS_WITH_AS(WeightFile::parse(make_file(R"({"a":{"dtype":"F32","shape":[-2],"data_offsets":[0,8]}})", data)),
                         doctest::Contains("tensor 'a': shape entry -2 is not a non-negative integer"), Error);
    CHECK_THROWS_WITH_AS(WeightFile::parse(make_file(R"({"a":{"dtype":"F32","shape":[2],"data_offsets":[8,0]}})", data)),
                         doctest::Contains("tensor 'a': data_offsets [8, 0] are reversed"), Error);
    CHECK_THROWS_WITH_AS(WeightFile::parse(make_file(R"({"a":{"dtype":"F32","shape":[2],"data_offsets":[0]}})", data)),
                         doctest::Contains("tensor 'a': \"data_offsets\" is not a pair"), Error);
  }
  SUBCASE("out-of-range offsets") {
    CHECK_THROWS_WITH_AS(WeightFile::parse(make_file(R"({"a":{"dtype":"F32","shape":[2],"data_offsets":[4,12]}})", data)),
                         doctest::Contains("tensor 'a': data ends at data byte 12"), Error);
  }
  SUBCASE("overlapping offsets") {
    const std::string h = R"({"a":{"dtype":"F32","shape":[2],"data_offsets":[0,8]},"b":{"dtype":"F32","shape":[1],"data_offsets":[4,8]}})";
    CHECK_THROWS_WITH_AS(WeightFile::parse(make_file(h, data)), doctest::Contains("overlaps tensor"), Error);
  }
  SUBCASE("bytes not covered by any tensor") {
    CHECK_THROWS_WITH_AS(WeightFile::parse(make_file(R"({"a":{"dtype":"F32","shape":[1],"data_offsets":[4,8]}})", data)),
                         doctest::Contains("data bytes 0..4 belong to no tensor"), Error);
    CHECK_THROWS_WITH_AS(WeightFile::parse(make_file("{" + ok_a + "}", data + "xxxx")),
                         doctest::Contains("data bytes 8..12 belong to no tensor"), Error);
  }
  SUBCASE("NaN and infinite weights") {
    CHECK_THROWS_WITH_AS(WeightFile::parse(make_file("{" + ok_a + "}", floats({1.0f, std::numeric_limits<float>::quiet_NaN()}))),
                         doctest::Contains("tensor 'a': element 1 (file byte"), Error);
    CHECK_THROWS_WITH_AS(WeightFile::parse(make_file("{" + ok_a + "}", floats({std::numeric_limits<float>::infinity(), 1.0f}))),
                         doctest::Contains("is infinite, expected finite values"), Error);
  }
  SUBCASE("metadata that is not string to string") {
    CHECK_THROWS_WITH_AS(WeightFile::parse(make_file(R"({"__metadata__":{"width":64},)" + ok_a + "}", data)),
                         doctest::Contains("metadata 'width' is not a string"), Error);
  }
}

TEST_CASE("weights: a model file needs the right tensors, shapes and metadata, each error named") {
  const int width = 4;
  const TensorMap good = test::random_tensors(UNet<>::expected_tensors(width), 5);
  REQUIRE_NOTHROW(UNet<>::from_tensors(good, width));
  TensorMap missing = good;
  missing.erase("dbn2.running_var");
  CHECK_THROWS_WITH_AS(UNet<>::from_tensors(missing, width), doctest::Contains("tensor 'dbn2.running_var' is missing, expected shape [8]"),
                       Error);
  TensorMap extra = good;
  extra["bn2.num_batches_tracked"] = {{}, {0.0f}};
  CHECK_THROWS_WITH_AS(UNet<>::from_tensors(extra, width),
                       doctest::Contains("tensor 'bn2.num_batches_tracked' is not part of a width-4 U-Net"), Error);
  TensorMap shaped = good;
  shaped["dec1.weight"].shape = {16, 8, 2, 8};
  CHECK_THROWS_WITH_AS(UNet<>::from_tensors(shaped, width),
                       doctest::Contains("tensor 'dec1.weight' has shape [16, 8, 2, 8], expected [32, 16, 4, 4]"), Error);
  CHECK_THROWS_WITH_AS(UNet<>::from_tensors(good, 5), doctest::Contains("expected [10] (a width-5 U-Net)"), Error);
  TensorMap nan = good;
  nan["out.bias"].values[0] = std::numeric_limits<float>::quiet_NaN();
  CHECK_THROWS_WITH_AS(UNet<>::from_tensors(nan, width), doctest::Contains("tensor 'out.bias' contains NaN"), Error);

  WeightFile file;
  file.tensors = good;
  CHECK_THROWS_WITH_AS(model::ModelInfo::from(file), doctest::Contains("metadata 'format' is missing"), Error);
  model::ModelInfo info;
  info.architecture = model::Architecture::UNet;
  info.width = width;
  info.glove = "glauser2019-44";
  info.joint_limits_min = std::vector<double>(25, -1.0);
  info.joint_limits_max = std::vector<double>(25, 1.0);
  info.to(file);
  CHECK(file.metadata.at("architecture") == "unet");  // the spelling of weights_format.md
  const model::ModelInfo back = model::ModelInfo::from(WeightFile::parse(file.serialize()));
  CHECK(back.architecture == model::Architecture::UNet);
  CHECK(back.width == 4);
  CHECK(back.glove == "glauser2019-44");
  CHECK(back.joint_limits_max == info.joint_limits_max);
  CHECK(!back.calibration_min);
  CHECK(back.calibration == model::CalibrationMode::OnTheFly);
  CHECK(back.inputs == 44);
  file.metadata["width"] = "four";
  CHECK_THROWS_WITH_AS(model::ModelInfo::from(file), doctest::Contains("metadata 'width' is 'four', expected an integer 1..4096"), Error);
  file.metadata["width"] = "4";
  file.metadata["calibration"] = "sometimes";
  CHECK_THROWS_WITH_AS(model::ModelInfo::from(file),
                       doctest::Contains("metadata 'calibration': calibration mode 'sometimes', expected none, training or onthefly"),
                       Error);
  file.metadata["calibration"] = "training";
  file.metadata["architecture"] = "lstm";
  CHECK_THROWS_WITH_AS(model::ModelInfo::from(file),
                       doctest::Contains("metadata 'architecture': architecture 'lstm', expected 'unet', 'fcn' or 'linear'"), Error);
  file.metadata["architecture"] = "linear";  // a linear map has no width: the file's 'width' is not read
  file.metadata["width"] = "four";
  CHECK(model::ModelInfo::from(file).architecture == model::Architecture::Linear);
  CHECK(model::ModelInfo::from(file).width == 0);
  file.metadata["width"] = "4";
  file.metadata["architecture"] = "unet";
  file.metadata["joint_limits_min"] = "[1, 2]";
  CHECK_THROWS_WITH_AS(model::ModelInfo::from(file), doctest::Contains("hold 2/25 numbers, expected 25 each"), Error);
}

TEST_CASE("model info: each architecture has one name, the model files' spelling, and reads back") {
  // weights_format.md's spellings, by enum value: an independent copy of the name table.
  const std::pair<model::Architecture, const char*> spelled[] = {
      {model::Architecture::UNet, "unet"}, {model::Architecture::Fcn, "fcn"}, {model::Architecture::Linear, "linear"}};
  CHECK(std::size(spelled) == static_cast<std::size_t>(model::Architecture::Count));
  for (const auto& [a, name] : spelled) {
    CHECK(std::string(model::to_string(a)) == name);
    CHECK(model::parse_architecture(name) == a);
    CHECK(model::architecture(name) == a);
  }
  CHECK(!model::parse_architecture("UNet"));  // spellings are exact
  CHECK(!model::parse_architecture("unet:64"));
  CHECK(!model::parse_architecture(""));
  CHECK_THROWS_WITH_AS(model::architecture("lstm"), "architecture 'lstm', expected 'unet', 'fcn' or 'linear'", Error);
}

TEST_CASE("model info: joint limits, glove and training range come from the metadata, checked against each other") {
  model::ModelInfo info;
  info.architecture = model::Architecture::Fcn;
  info.width = 8;
  info.glove = "glauser2019-44";
  for (std::size_t d = 0; d < hand::kDofCount; ++d) {  // limits of its own, not the reference hand's
    info.joint_limits_min.push_back(-0.5 - 0.01 * static_cast<double>(d));
    info.joint_limits_max.push_back(0.75 + 0.02 * static_cast<double>(d));
  }
  const hand::JointLimits limits = info.joint_limits();
  for (std::size_t d = 0; d < hand::kDofCount; ++d) {
    CHECK(limits.min()[d] == info.joint_limits_min[d]);
    CHECK(limits.max()[d] == info.joint_limits_max[d]);
  }

  const grid::GloveDescription glove = info.glove_of_model();
  CHECK(glove.id() == "glauser2019-44");
  CHECK(glove.cell_count() == 44);
  info.inputs = 14;
  CHECK_THROWS_WITH_AS(info.glove_of_model(), doctest::Contains("metadata 'inputs' is 14 but glove 'glauser2019-44' has 44 cells"), Error);
  info.inputs = 44;

  CHECK(!info.training_range(glove.cell_names(), glove.calibration().config()));
  info.calibration_min = std::vector<double>(44), info.calibration_max = std::vector<double>(44);
  for (int c = 0; c < 44; ++c) {
    (*info.calibration_min)[static_cast<std::size_t>(c)] = 10.0 + c;
    (*info.calibration_max)[static_cast<std::size_t>(c)] = 20.0 + 2.0 * c;
  }
  const auto range = info.training_range(glove.cell_names(), glove.calibration().config());
  REQUIRE(range);
  CHECK(range->size() == 44);
  CHECK(range->names() == glove.cell_names());
  for (int c = 0; c < 44; ++c) {
    CHECK(range->min()(c) == 10.0 + c);
    CHECK(range->max()(c) == 20.0 + 2.0 * c);
  }
  info.calibration_min->pop_back(), info.calibration_max->pop_back();
  CHECK_THROWS_WITH_AS(info.training_range(glove.cell_names(), glove.calibration().config()),
                       doctest::Contains("metadata 'calibration_min' holds 43 numbers, expected 44 (one per cell)"), Error);
}
