// io::AtomicFile: a file is written whole or not at all, and what is left behind, judged by the file
// system's own view of the folder (the names in it, the bytes read back).
#include <doctest/doctest.h>

#include <glovepose/io/atomic_file.hpp>
#include <glovepose/io/tensor_file.hpp>

#include <dirent.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <set>
#include <stdexcept>
#include <string>

#include "test_files.hpp"

using glovepose::Error;
using glovepose::io::AtomicFile;
using glovepose::test::slurp;

namespace {

// A fresh, empty folder in the scratch directory.
std::string empty_folder(const std::string& name) {
  const std::string dir = glovepose::test::temp_path(name);
  (void)std::system(("rm -rf '" + dir + "' && mkdir -p '" + dir + "'").c_str());
  return dir;
}

std::set<std::string> names_in(const std::string& dir) {
  std::set<std::string> names;
  DIR* d = opendir(dir.c_str());
  REQUIRE(d != nullptr);
  while (const dirent* e = readdir(d))
    if (std::string(e->d_name) != "." && std::string(e->d_name) != "..") names.insert(e->d_name);
  closedir(d);
  return names;
}

void put(const std::string& path, const std::string& bytes) { std::ofstream(path, std::ios::binary) << bytes; }

// The id of a process that has ended (a child that exited and was reaped).
long ended_process() {
  const pid_t child = fork();
  if (child == 0) _exit(0);
  int status = 0;
  waitpid(child, &status, 0);
  return static_cast<long>(child);
}

}  // namespace

TEST_CASE("atomic file: commit replaces the target with exactly the bytes written, and nothing else is left") {
  const std::string dir = empty_folder("atomic_commit");
  const std::string target = dir + "/out.txt";
  put(target, "the previous contents\n");
  std::string expected;
  for (int i = 0; i < 20000; ++i) expected += "line " + std::to_string(i) + "\n";  // larger than the writer's buffer
  {
    AtomicFile file(target, "test file");
    file.stream() << expected.substr(0, 1000);
    file.write(expected.data() + 1000, expected.size() - 1000);
    CHECK(slurp(target) == "the previous contents\n");  // unchanged until commit
    CHECK(names_in(dir).size() == 2);                    // the target and one temporary file
    file.commit();
  }
  CHECK(slurp(target) == expected);
  CHECK(names_in(dir) == std::set<std::string>{"out.txt"});
}

TEST_CASE("atomic file: without commit (an exception while filling it) the target keeps its contents and no file is left") {
  const std::string dir = empty_folder("atomic_abandon");
  const std::string target = dir + "/model.safetensors";
  put(target, "old");
  CHECK_THROWS_AS(glovepose::io::write_file_whole(target, "model file",
                                                  [](std::ostream& out) {
                                                    out << "half of a file";
                                                    throw std::runtime_error("the writer failed");
                                                  }),
                  std::runtime_error);
  CHECK(slurp(target) == "old");
  CHECK(names_in(dir) == std::set<std::string>{"model.safetensors"});
  // A target that did not exist is not created.
  CHECK_THROWS_AS(glovepose::io::write_file_whole(dir + "/new.txt", "test file", [](std::ostream&) { throw std::runtime_error("no"); }),
                  std::runtime_error);
  CHECK(names_in(dir) == std::set<std::string>{"model.safetensors"});
}

TEST_CASE("atomic file: a write the system refuses throws naming the file and the cause, and the old file stays") {
  const std::string dir = empty_folder("atomic_refused");
  const std::string target = dir + "/data.safetensors";
  put(target, "old bytes");
  glovepose::io::TensorFile big;
  big.tensors["x"] = glovepose::io::RawTensor{glovepose::io::DType::U8, {200000}, std::string(200000, 'x')};
  // The largest file this process may write: 64 KiB (EFBIG beyond it, SIGXFSZ ignored).
  rlimit old_limit{};
  getrlimit(RLIMIT_FSIZE, &old_limit);
  const auto old_handler = std::signal(SIGXFSZ, SIG_IGN);
  rlimit small = old_limit;
  small.rlim_cur = 64 * 1024;
  REQUIRE(setrlimit(RLIMIT_FSIZE, &small) == 0);
  std::string message;
  try {
    big.write(target, "dataset file");
  } catch (const Error& e) {
    message = e.what();
  }
  setrlimit(RLIMIT_FSIZE, &old_limit);
  std::signal(SIGXFSZ, old_handler);
  CHECK(message == "dataset file '" + target + "': cannot write: " + std::strerror(EFBIG) + "; the previous file is unchanged");
  CHECK(slurp(target) == "old bytes");
  CHECK(names_in(dir) == std::set<std::string>{"data.safetensors"});
  // A folder that does not exist: the cause is named, nothing is created.
  CHECK_THROWS_WITH_AS(AtomicFile(dir + "/no_such_folder/x", "test file"),
                       doctest::Contains(("test file '" + dir + "/no_such_folder/x': cannot open for writing").c_str()), Error);
}

TEST_CASE("atomic file: a commit removes the temporary files of this target that killed processes left, and only those") {
  const std::string dir = empty_folder("atomic_orphans");
  const std::string target = dir + "/cal.txt";
  const std::string dead = std::to_string(ended_process());
  const std::string live = std::to_string(static_cast<long>(getppid()));  // the test runner: running
  const std::string orphan = "cal.txt.partial-" + dead + "-0", running = "cal.txt.partial-" + live + "-3";
  const std::string other_target = "other.txt.partial-" + dead + "-0", not_ours = "cal.txt.partial-notes";
  for (const std::string& name : {orphan, running, other_target, not_ours}) put(dir + "/" + name, "x");
  glovepose::io::write_file_whole(target, "calibration file", [](std::ostream& out) { out << "new"; });
  CHECK(slurp(target) == "new");
  CHECK(names_in(dir) == std::set<std::string>{"cal.txt", running, other_target, not_ours});
}
