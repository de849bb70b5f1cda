// ReadError and WriteError: a file that cannot be read and an output that cannot be written
// are told apart (the CLI's exit codes 2 and 3), and both remain IOErrors for older callers.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "meshmark/core/error.h"
#include "meshmark/io/io.h"
#include "test_data.h"

namespace meshmark {
namespace {

Mesh triangle() {
  Eigen::MatrixX3d V(3, 3);
  V << 0, 0, 0, 1, 0, 0, 0, 1, 0;
  Eigen::MatrixX3i F(1, 3);
  F << 0, 1, 2;
  return make_mesh(V, F);
}

TEST(ErrorKinds, AMissingFileOrADirectoryIsAReadError) {
  const std::string dir = test::scratch_dir();
  EXPECT_THROW(read_mesh(dir + "/missing.obj"), ReadError);
  std::filesystem::create_directory(dir + "/folder.obj");
  EXPECT_THROW(read_mesh(dir + "/folder.obj"), ReadError);
  EXPECT_THROW(read_file(dir + "/missing.key"), ReadError);
  try {
    read_mesh(dir + "/missing.obj");
  } catch (const IOError& e) {  // older catch sites still see it
    EXPECT_NE(std::string(e.what()).find("missing.obj"), std::string::npos) << e.what();
  }
}

TEST(ErrorKinds, AMalformedFileIsInvalidInputNotAReadError) {
  const std::string path = test::scratch_dir() + "/bad.off";
  std::ofstream(path) << "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n";
  try {
    read_mesh(path);
    FAIL() << "read a face with vertex index 7 of 3";
  } catch (const IOError& e) {
    FAIL() << "an IOError for content: " << e.what();
  } catch (const InvalidInputError&) {
  }
}

TEST(ErrorKinds, AnOutputThatCannotBeWrittenIsAWriteError) {
  const std::string dir = test::scratch_dir();
  // A folder that does not exist, and one whose "parent" is a regular file (ENOTDIR even for
  // root, whom permissions do not stop).
  EXPECT_THROW(write_mesh(dir + "/no/such/folder/out.obj", triangle()), WriteError);
  std::ofstream(dir + "/plain") << "x";
  EXPECT_THROW(write_mesh(dir + "/plain/out.obj", triangle()), WriteError);
  EXPECT_THROW(write_file_atomically(dir + "/plain/out.txt", "bytes"), WriteError);
  // A directory where the file should go is refused, not replaced.
  std::filesystem::create_directory(dir + "/taken.obj");
  EXPECT_THROW(write_mesh(dir + "/taken.obj", triangle()), WriteError);
  EXPECT_TRUE(std::filesystem::is_directory(dir + "/taken.obj"));
}

}  // namespace
}  // namespace meshmark
