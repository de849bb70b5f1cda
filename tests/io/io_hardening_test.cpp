// What a hostile user can hand the readers and writers: byte-order marks, faces of fewer than
// three vertices, files that are not regular files, escape sequences in quoted text, umasks
// and existing modes, temporaries left by a killed writer, near-coincident vertices.

#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <future>

#include "meshmark/core/error.h"
#include "meshmark/io/io.h"
#include "test_data.h"

using namespace meshmark;

namespace {

const std::string kBom = "\xEF\xBB\xBF";

// A tetrahedron in every text format, written out by hand.
const std::string kObj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
const std::string kOff =
    "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
const std::string kPlyHeader =
    "ply\nformat ascii 1.0\nelement vertex 4\nproperty double x\nproperty double y\n"
    "property double z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n";
const std::string kPly =
    kPlyHeader + "0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";

Eigen::MatrixX3d tetrahedron_positions() {
  Eigen::MatrixX3d V(4, 3);
  V << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1;
  return V;
}

Eigen::MatrixX3i tetrahedron_triangles() {
  Eigen::MatrixX3i F(4, 3);
  F << 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3;
  return F;
}

std::string ascii_stl_triangle() {
  return "solid t\nfacet normal 0 0 1\n outer loop\n  vertex 0 0 0\n  vertex 1 0 0\n"
         "  vertex 0 1 0\n endloop\nendfacet\nendsolid t\n";
}

mode_t mode_of(const std::string& path) {
  struct stat st {};
  EXPECT_EQ(::stat(path.c_str(), &st), 0) << path;
  return st.st_mode & 0777;
}

// Runs a shell command line, stdout and stderr together.
test::CliRun shell(const std::string& command) {
  test::CliRun r;
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (!pipe) return r;
  char buf[4096];
  std::size_t n;
  while ((n = fread(buf, 1, sizeof buf, pipe)) > 0) r.out.append(buf, n);
  const int status = pclose(pipe);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

bool has_control_bytes(const std::string& text) {
  for (const char c : text)
    if ((static_cast<unsigned char>(c) < 0x20 && c != '\n') || c == 0x7f) return true;
  return false;
}

}  // namespace

// ----- 1. UTF-8 byte-order mark -----

TEST(IoBom, EveryTextFormatSkipsALeadingByteOrderMark) {
  const struct {
    FileFormat format;
    std::string text;
  } cases[] = {{FileFormat::Obj, kObj}, {FileFormat::Off, kOff}, {FileFormat::Ply, kPly}};
  for (const auto& c : cases) {
    SCOPED_TRACE(format_name(c.format));
    const Mesh m = read_mesh_from_bytes(kBom + c.text, c.format, "bom");
    EXPECT_EQ(m.V, tetrahedron_positions());
    EXPECT_EQ(m.F, tetrahedron_triangles());
  }
  const Mesh stl = read_mesh_from_bytes(kBom + ascii_stl_triangle(), FileFormat::Stl, "bom.stl");
  EXPECT_EQ(stl.encoding, Encoding::Ascii);
  ASSERT_EQ(stl.V.rows(), 3);
  EXPECT_EQ(stl.V.row(1), Eigen::RowVector3d(1, 0, 0));
}

TEST(IoBom, BinaryPlyHeaderWithAByteOrderMarkReads) {
  std::string ply =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
      "property float y\nproperty float z\nelement face 1\n"
      "property list uchar int vertex_indices\nend_header\n";
  const float xyz[9] = {0, 0, 0, 2, 0, 0, 0, 3, 0};
  ply.append(reinterpret_cast<const char*>(xyz), sizeof xyz);
  const std::int32_t face[3] = {0, 1, 2};
  ply += '\x03';
  ply.append(reinterpret_cast<const char*>(face), sizeof face);
  const Mesh m = read_mesh_from_bytes(kBom + ply, FileFormat::Ply, "bom.ply");
  ASSERT_EQ(m.V.rows(), 3);
  EXPECT_EQ(m.V.row(2), Eigen::RowVector3d(0, 3, 0));
  EXPECT_EQ(m.F.row(0), Eigen::RowVector3i(0, 1, 2));
}

TEST(IoBom, WritingBackKeepsTheByteOrderMarkAndMovesTheRightVertex) {
  Mesh m = read_mesh_from_bytes(kBom + kObj, FileFormat::Obj, "bom.obj");
  m.V(0, 0) = 0.5;
  const std::string out = write_mesh_to_bytes(m, FileFormat::Obj);
  EXPECT_EQ(out, kBom + "v 0.5 0 0" + kObj.substr(7));
}

// ----- 2. faces of fewer than three vertices -----

TEST(IoShortFaces, AFaceOfFewerThanThreeVerticesIsAnErrorNamingFileLineAndFace) {
  const struct {
    FileFormat format;
    std::string bytes;
    std::size_t line;
    const char* mentions;
  } cases[] = {
      {FileFormat::Obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 2 3\n", 5, "face 2: 2 vertices"},
      {FileFormat::Obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf\nf 1 2 3\n", 4, "face 1: 0 vertices"},
      {FileFormat::Off, "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n2 0 1\n", 7,
       "face 1: 2 vertices"},
      {FileFormat::Ply,
       "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n"
       "property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n"
       "0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n1 3\n",
       15, "face 1: 1 vertices"},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.bytes);
    try {
      (void)read_mesh_from_bytes(c.bytes, c.format, "short");
      ADD_FAILURE() << "read without an error";
    } catch (const InvalidInputError& e) {
      EXPECT_EQ(e.line(), c.line) << e.what();
      EXPECT_NE(std::string(e.what()).find(c.mentions), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("at least 3"), std::string::npos) << e.what();
    }
  }
}

TEST(IoShortFaces, BinaryPlyNamesTheFace) {
  std::string ply =
      "ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty float x\n"
      "property float y\nproperty float z\nelement face 1\n"
      "property list uchar int vertex_indices\nend_header\n";
  ply += std::string(36, '\0');
  ply += std::string("\x02\0\0\0\0\0\0\0\x01", 9);
  try {
    (void)read_mesh_from_bytes(ply, FileFormat::Ply, "short.ply");
    ADD_FAILURE() << "read without an error";
  } catch (const InvalidInputError& e) {
    EXPECT_EQ(e.line(), 0u);
    EXPECT_NE(std::string(e.what()).find("face 0: 2 vertices"), std::string::npos) << e.what();
  }
}

// ----- 3. --format with an OUT without extension -----

TEST(IoWrite, AGivenFormatNeedsNoExtension) {
  const std::string dir = test::scratch_dir();
  const Mesh m = make_mesh(tetrahedron_positions(), tetrahedron_triangles());
  WriteOptions wo;
  wo.format = FileFormat::Ply;
  write_mesh(dir + "/no-extension", m, wo);
  const std::string bytes = read_file(dir + "/no-extension");
  EXPECT_EQ(bytes.rfind("ply\n", 0), 0u);
  const Mesh back = read_mesh_from_bytes(bytes, FileFormat::Ply, "no-extension");
  EXPECT_EQ(back.V, m.V);
  EXPECT_EQ(back.F, m.F);
}

// ----- 4. modes -----

TEST(IoWrite, NewFilesHonourTheUmaskAndExistingFilesKeepTheirMode) {
  const std::string dir = test::scratch_dir();
  const Mesh m = make_mesh(tetrahedron_positions(), tetrahedron_triangles());
  for (const mode_t mask : {mode_t{022}, mode_t{077}, mode_t{002}}) {
    const mode_t previous = ::umask(mask);
    const std::string path = dir + "/new-" + std::to_string(mask) + ".obj";
    write_mesh(path, m);
    ::umask(previous);
    EXPECT_EQ(mode_of(path), 0666 & ~mask) << "umask " << std::oct << mask;
  }
  for (const mode_t mode : {mode_t{0600}, mode_t{0640}, mode_t{0444}}) {
    const std::string path = dir + "/existing-" + std::to_string(mode) + ".obj";
    std::ofstream(path) << "old";
    ASSERT_EQ(::chmod(path.c_str(), mode), 0);
    const mode_t previous = ::umask(022);
    write_mesh(path, m);
    ::umask(previous);
    EXPECT_EQ(mode_of(path), mode) << std::oct << mode;
    EXPECT_NE(read_file(path), "old");
  }
}

// ----- 5. escaping -----

TEST(IoEscaping, PrintableEscapesWhatATerminalWouldActOn) {
  EXPECT_EQ(printable("plain text: 1.5 /a/b"), "plain text: 1.5 /a/b");
  EXPECT_EQ(printable("\x1b[31mred\x07"), "\\x1b[31mred\\x07");
  EXPECT_EQ(printable(std::string("a\0b\tc\x7f", 6)), "a\\x00b\\x09c\\x7f");
  EXPECT_EQ(printable("caf\xC3\xA9 \xE2\x82\xAC"), "caf\xC3\xA9 \xE2\x82\xAC") << "UTF-8 is kept";
  EXPECT_EQ(printable("\xC2\x9B"
                      "2J"),
            "\\xc2\\x9b2J")
      << "C1 CSI as UTF-8";
  EXPECT_EQ(printable("\x9B"
                      "2J"),
            "\\x9b2J")
      << "a lone C1 byte";
  EXPECT_EQ(printable("\xE2\x80\xAE"
                      "txt"),
            "\\xe2\\x80\\xaetxt")
      << "right-to-left override";
  EXPECT_EQ(printable("\xC0\xAF \xED\xA0\x80 \xFF"), "\\xc0\\xaf \\xed\\xa0\\x80 \\xff")
      << "overlong, surrogate, invalid";
  EXPECT_EQ(printable("cut \xE2\x82"), "cut \\xe2\\x82") << "a truncated sequence";
  const std::string once = printable("\x1b]0;title\x07 back\\slash");
  EXPECT_EQ(printable(once), once) << "idempotent";
}

TEST(IoEscaping, ErrorsQuotingFileContentsOrNamesCarryNoControlBytes) {
  const std::string name = "evil\x1b[2Jname.obj";
  try {
    (void)read_mesh_from_bytes("v 0 0 \x1b]0;pwned\x07\n", FileFormat::Obj, name);
    ADD_FAILURE() << "read without an error";
  } catch (const InvalidInputError& e) {
    const std::string what = e.what();
    EXPECT_FALSE(has_control_bytes(what)) << what;
    EXPECT_NE(what.find("evil\\x1b[2Jname.obj:1:"), std::string::npos) << what;
    EXPECT_NE(what.find("'\\x1b]0;pwned\\x07'"), std::string::npos) << what;
    EXPECT_EQ(e.file(), name) << "the accessor gives the name as it was";
  }
  try {
    (void)read_file("/nonexistent/\x1b[31m.obj");
    ADD_FAILURE() << "read without an error";
  } catch (const IOError& e) {
    EXPECT_FALSE(has_control_bytes(e.what())) << e.what();
  }
}

// ----- 6. temporaries left by a killed writer -----

TEST(IoWrite, StaleTemporariesOfTheSameTargetAreRemovedAndNothingElse) {
  const std::string dir = test::scratch_dir();
  // A process that has exited: its PID names no running process (until reused).
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  ASSERT_GT(child, 0);
  ASSERT_EQ(::waitpid(child, nullptr, 0), child);
  const std::string dead = std::to_string(child), alive = std::to_string(::getppid());
  const std::string stale = ".out.obj.meshmark-" + dead + "-a1B2c3";
  const std::string kept[] = {
      ".out.obj.meshmark-" + alive + "-a1B2c3",   // its writer still runs
      ".out.obj.meshmark-" + dead + "-a1B2c",     // not our pattern (five letters)
      ".out.obj.meshmark-" + dead + "-a1B2c3x",   // not our pattern (seven)
      ".out.obj.meshmark-XXXXXX",                 // no PID
      ".other.obj.meshmark-" + dead + "-a1B2c3",  // another target
      "out.obj.meshmark-" + dead + "-a1B2c3",     // not hidden
  };
  std::ofstream(dir + "/" + stale) << "half a mesh";
  for (const std::string& k : kept) std::ofstream(dir + "/" + k) << "someone's";
  write_mesh(dir + "/out.obj", make_mesh(tetrahedron_positions(), tetrahedron_triangles()));
  EXPECT_FALSE(std::filesystem::exists(dir + "/" + stale));
  for (const std::string& k : kept) EXPECT_TRUE(std::filesystem::exists(dir + "/" + k)) << k;
  std::size_t entries = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    (void)e;
    ++entries;
  }
  EXPECT_EQ(entries, std::size(kept) + 1) << "the kept files and out.obj, no temporary";
}

// ----- 7. only regular files are read -----

TEST(IoRegularFiles, DirectoriesDevicesAndFifosAreRefusedWithoutReading) {
  const std::string dir = test::scratch_dir();
  std::filesystem::create_directories(dir + "/folder.obj");
  std::filesystem::create_symlink("/dev/zero", dir + "/zero.ply");
  ASSERT_EQ(::mkfifo((dir + "/fifo.off").c_str(), 0600), 0);
  const struct {
    std::string path;
    const char* kind;
  } cases[] = {{dir + "/folder.obj", "a directory"},
               {dir + "/zero.ply", "a character device"},
               {dir + "/fifo.off", "a FIFO"}};
  for (const auto& c : cases) {
    SCOPED_TRACE(c.path);
    // A reader blocked on the FIFO would hang the test: read in a thread and, if it has not
    // answered in time, open the FIFO's other end to release it.
    auto reading = std::async(std::launch::async, [&] {
      try {
        (void)read_mesh(c.path);
        return std::string("read");
      } catch (const IOError& e) {
        return std::string(e.what());
      }
    });
    if (reading.wait_for(std::chrono::seconds(10)) != std::future_status::ready) {
      ADD_FAILURE() << "the read blocks";
      const int fd = ::open(c.path.c_str(), O_WRONLY | O_NONBLOCK);
      if (fd >= 0) ::close(fd);
    }
    const std::string what = reading.get();
    EXPECT_EQ(what.rfind(c.path + ":", 0), 0u) << what;
    EXPECT_NE(what.find(c.kind), std::string::npos) << what;
  }
}

// Writing over something that is not a regular file (a device, a FIFO, a symbolic link, a
// directory) is refused, naming it, and leaves it as it was: a rename over it would replace
// /dev/null itself when run as root.
TEST(IoRegularFiles, WritesNeverReplaceDevicesFifosLinksOrDirectories) {
  const std::string dir = test::scratch_dir();
  std::filesystem::create_symlink("/dev/null", dir + "/null.ply");
  std::filesystem::create_symlink(dir + "/elsewhere.ply", dir + "/link.ply");
  ASSERT_EQ(::mkfifo((dir + "/fifo.ply").c_str(), 0600), 0);
  std::filesystem::create_directories(dir + "/folder.ply");
  for (const std::string name : {"null.ply", "link.ply", "fifo.ply", "folder.ply"}) {
    const std::string path = dir + "/" + name;
    SCOPED_TRACE(path);
    const std::filesystem::file_status before = std::filesystem::symlink_status(path);
    try {
      write_file_atomically(path, "ply\n");
      ADD_FAILURE() << "written";
    } catch (const IOError& e) {
      EXPECT_EQ(std::string(e.what()).rfind(path + ": not a regular file", 0), 0u) << e.what();
    }
    EXPECT_EQ(std::filesystem::symlink_status(path).type(), before.type());
  }
  EXPECT_FALSE(std::filesystem::exists(dir + "/elsewhere.ply"));
  // A regular file is still replaced.
  write_file_atomically(dir + "/plain.ply", "one");
  write_file_atomically(dir + "/plain.ply", "two");
  EXPECT_EQ(read_file(dir + "/plain.ply"), "two");
}

TEST(IoRegularFiles, SizeLimitsAreCheckedAndNamed) {
  const std::string dir = test::scratch_dir();
  std::ofstream(dir + "/key") << std::string(1 << 20, 'k');
  EXPECT_EQ(read_file(dir + "/key", 1 << 20, "key file").size(), std::size_t{1} << 20);
  std::ofstream(dir + "/key", std::ios::app) << 'k';
  try {
    (void)read_file(dir + "/key", 1 << 20, "key file");
    ADD_FAILURE() << "read a file over the limit";
  } catch (const IOError& e) {
    EXPECT_NE(std::string(e.what()).find("key file is larger than 1 MiB"), std::string::npos)
        << e.what();
  }
}

TEST(IoRegularFiles, TheCommandLineRefusesThemWithExitCodeTwo) {
  const std::string spot = test::data_mesh("spot.obj");
  MESHMARK_REQUIRE(spot, "spot.obj");
  const std::string dir = test::scratch_dir();
  const std::string cli = MESHMARK_CLI;
  std::filesystem::create_symlink("/dev/zero", dir + "/zero.ply");
  ASSERT_EQ(::mkfifo((dir + "/fifo.obj").c_str(), 0600), 0);
  std::filesystem::create_directories(dir + "/keys");
  std::ofstream(dir + "/big.key") << std::string((1 << 20) + 1, 'k');
  // A memory limit and a time limit, so that a regression fails instead of eating the machine.
#if defined(__SANITIZE_ADDRESS__)
  // AddressSanitizer reserves terabytes of address space: a memory cap would stop it at start.
  const std::string limits = "timeout 60 ";
#else
  const std::string limits = "ulimit -v 2000000; timeout 60 ";
#endif
  const struct {
    std::string args;
    const char* mentions;
  } cases[] = {
      {"extract " + dir + "/zero.ply", "character device"},
      {"extract " + dir + "/fifo.obj", "FIFO"},
      {"extract " + spot + " --key-file " + dir + "/keys", "key file is a directory"},
      {"extract " + spot + " --key-file /dev/zero", "key file is a character device"},
      {"extract " + spot + " --key-file " + dir + "/fifo.obj", "key file is a FIFO"},
      {"extract " + spot + " --key-file " + dir + "/big.key", "larger than 1 MiB"},
  };
  for (const auto& c : cases) {
    const test::CliRun r = shell(limits + cli + " " + c.args);
    EXPECT_EQ(r.code, 2) << c.args << "\n" << r.out;
    EXPECT_NE(r.out.find(c.mentions), std::string::npos) << c.args << "\n" << r.out;
  }
}

// ----- 8. --weld-tolerance in every format -----

namespace {

// Two triangles sharing an edge whose shared corners are stored twice, 1e-9 apart (a seam),
// plus an unreferenced vertex 1e-9 from corner 0.
Mesh seamed_mesh() {
  Eigen::MatrixX3d V(7, 3);
  V << 0, 0, 0,        //
      1, 0, 0,         //
      0, 1, 0,         //
      1 + 1e-9, 0, 0,  // the copy of 1
      0, 1 - 1e-9, 0,  // the copy of 2
      1, 1, 0.5,       //
      1e-9, 0, 0;      // unreferenced
  Eigen::MatrixX3i F(2, 3);
  F << 0, 1, 2, 3, 5, 4;
  return make_mesh(V, F);
}

}  // namespace

TEST(IoWeld, EveryFormatWeldsWithinTheToleranceAndWritesBackEveryStoredVertex) {
  const Mesh source = seamed_mesh();
  const struct {
    FileFormat format;
    Encoding encoding;
  } cases[] = {{FileFormat::Obj, Encoding::Ascii},
               {FileFormat::Off, Encoding::Ascii},
               {FileFormat::Ply, Encoding::Ascii},
               {FileFormat::Ply, Encoding::BinaryBigEndian}};
  ReadOptions weld;
  weld.weld_tolerance = 1e-6;
  for (const auto& c : cases) {
    SCOPED_TRACE(std::string(format_name(c.format)) + " " + encoding_name(c.encoding));
    WriteOptions wo;
    wo.encoding = c.encoding;
    const std::string file = write_mesh_to_bytes(source, c.format, wo);
    Mesh m = read_mesh_from_bytes(file, c.format, "seam", weld);
    // Expected by hand: 1 and 3, 2 and 4 become one vertex each; 6 is unreferenced and stays.
    ASSERT_EQ(m.V.rows(), 5);
    Eigen::MatrixX3i F(2, 3);
    F << 0, 1, 2, 1, 3, 2;
    EXPECT_EQ(m.F, F);
    EXPECT_EQ(m.V.row(4), source.V.row(6));
    EXPECT_EQ(read_mesh_from_bytes(file, c.format, "seam").V.rows(), 7) << "no weld at 0";
    // Move every referenced vertex: each stored copy moves by its vertex's displacement.
    const Eigen::RowVector3d d(0.25, -0.5, 0.125);
    for (int i = 0; i < 4; ++i) m.V.row(i) += d;
    const Mesh back = read_mesh_from_bytes(write_mesh_to_bytes(m, c.format), c.format, "seam");
    ASSERT_EQ(back.V.rows(), 7) << "the file keeps its own vertices";
    for (int i = 0; i < 6; ++i)
      EXPECT_LE((back.V.row(i) - (source.V.row(i) + d)).cwiseAbs().maxCoeff(), 1e-15)
          << "vertex " << i;
    EXPECT_EQ(back.V.row(6), source.V.row(6)) << "unreferenced vertices never move";
    EXPECT_EQ(file_faces(back), file_faces(source));
  }
}

TEST(IoWeld, ToleranceMustBeAFiniteNonNegativeDistance) {
  for (const double bad :
       {-1.0, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    ReadOptions ro;
    ro.weld_tolerance = bad;
    EXPECT_THROW(read_mesh_from_bytes(kObj, FileFormat::Obj, "t.obj", ro), InvalidArgumentError)
        << bad;
  }
}

TEST(IoWeld, HugeCoordinatesAndATinyToleranceWeldOnlyWhatIsClose) {
  // x / tolerance far beyond the 64-bit range: the grid must neither overflow nor lump
  // everything together.
  Eigen::MatrixX3d V(4, 3);
  V << 1e300, 0, 0, -1e300, 1, 0, 1e300, 0, 1e-300, 5e299, 2, 0;
  Eigen::MatrixX3i F(2, 3);
  F << 0, 1, 3, 2, 3, 1;
  ReadOptions ro;
  ro.weld_tolerance = 1e-200;
  const Mesh m = read_mesh_from_bytes(write_mesh_to_bytes(make_mesh(V, F), FileFormat::Obj),
                                      FileFormat::Obj, "huge.obj", ro);
  ASSERT_EQ(m.V.rows(), 3) << "vertices 0 and 2 are 1e-300 apart; no others are close";
  EXPECT_EQ(m.F(1, 0), 0);
}

// ----- float32 outputs -----

TEST(IoWrite, CoordinatesBeyondFloat32AreRefusedWhereFloat32IsStored) {
  Eigen::MatrixX3d V = tetrahedron_positions();
  V(2, 1) = 1e308;
  Mesh m = make_mesh(V, tetrahedron_triangles());
  m.source_path = "big.obj";
  WriteOptions single;
  single.single_precision = true;
  for (const auto& [format, options] :
       {std::pair{FileFormat::Stl, WriteOptions{}}, std::pair{FileFormat::Ply, single}}) {
    try {
      (void)write_mesh_to_bytes(m, format, options);
      ADD_FAILURE() << format_name(format) << ": written";
    } catch (const InvalidArgumentError& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.rfind("big.obj: coordinates do not fit in float32", 0), 0u) << what;
      EXPECT_NE(what.find("vertex 2: y = 1e+308"), std::string::npos) << what;
    }
  }
  // Doubles hold it.
  const Mesh back =
      read_mesh_from_bytes(write_mesh_to_bytes(m, FileFormat::Ply), FileFormat::Ply, "double.ply");
  EXPECT_EQ(back.V, V);
}
