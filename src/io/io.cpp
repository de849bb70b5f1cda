#include "meshmark/io/io.h"

#include <dirent.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <limits>
#include <random>

#include <fmt/format.h>

#include "core/text_scan.h"
#include "io/io_formats.h"
#include "meshmark/core/error.h"

namespace meshmark {

namespace detail {

void fail(const std::string& name, std::size_t line, const std::string& message) {
  throw InvalidInputError(name, line, message);
}

void append_position(std::string& out, const Eigen::MatrixX3d& V, Eigen::Index i) {
  append_double(out, V(i, 0));
  out += ' ';
  append_double(out, V(i, 1));
  out += ' ';
  append_double(out, V(i, 2));
}

Mesh assemble(Parsed parsed, std::string* image_bytes, FileFormat format, Encoding encoding,
              const std::string& name, const ReadOptions& options,
              std::shared_ptr<const FormatImage> extra) {
  if (parsed.faces.size() == 0) fail(name, 0, "the file has no faces");
  const bool split_format =
      format != FileFormat::Off && format != FileFormat::Obj && format != FileFormat::Ply;
  if (split_format || options.weld_tolerance > 0) weld_vertices(parsed, options.weld_tolerance);
  Mesh mesh;
  const auto nv = static_cast<Eigen::Index>(parsed.xyz.size() / 3);
  mesh.V = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>(
      parsed.xyz.data(), nv, 3);
  set_faces(mesh, std::move(parsed.faces));
  if (mesh.F.rows() == 0) fail(name, 0, "no face has three or more vertices");
  mesh.format = format;
  mesh.encoding = encoding;
  mesh.source_path = name;
  if (options.keep_image) {
    auto image = std::make_shared<FileImage>();
    image->format = format;
    image->encoding = encoding;
    if (image_bytes) image->bytes = std::move(*image_bytes);
    image->slots = std::move(parsed.slots);
    image->regular = parsed.regular;
    auto by_offset = [](const CoordSlot& a, const CoordSlot& b) { return a.offset < b.offset; };
    if (!std::is_sorted(image->slots.begin(), image->slots.end(), by_offset))
      std::sort(image->slots.begin(), image->slots.end(), by_offset);
    if (split_format || options.weld_tolerance > 0) image->V = mesh.V;
    record_connectivity(*image, mesh);
    image->extra = std::move(extra);
    elide_sections(*image, mesh, parsed.elidable);
    mesh.image = std::move(image);
  }
  return mesh;
}

Polygons triangles_of_corners(std::vector<int> corners) {
  Polygons faces;
  std::vector<std::int64_t> offsets(corners.size() / 3 + 1);
  for (std::size_t t = 0; t < offsets.size(); ++t) offsets[t] = static_cast<std::int64_t>(3 * t);
  corners.resize(3 * (offsets.size() - 1));
  faces.offsets = std::move(offsets);
  faces.indices = std::move(corners);
  return faces;
}

Mesh assemble_welded(Parsed parsed, FileFormat format, const std::string& name,
                     const ReadOptions& options, std::vector<int>& vertex_of_point) {
  const std::size_t np = parsed.xyz.size() / 3;
  parsed.slots.assign(np, CoordSlot{});
  for (std::size_t p = 0; p < np; ++p) parsed.slots[p].vertex = static_cast<std::int32_t>(p);
  weld_vertices(parsed, options.weld_tolerance);
  vertex_of_point.resize(np);
  for (std::size_t p = 0; p < np; ++p) vertex_of_point[p] = parsed.slots[p].vertex;
  parsed.slots.clear();
  ReadOptions welded = options;
  welded.weld_tolerance = 0;
  welded.keep_image = false;
  return assemble(std::move(parsed), nullptr, format, Encoding::BinaryLittleEndian, name, welded);
}

void attach_image(Mesh& mesh, std::shared_ptr<const FormatImage> extra,
                  const ReadOptions& options) {
  if (!options.keep_image) return;
  auto image = std::make_shared<FileImage>();
  image->format = mesh.format;
  image->encoding = mesh.encoding;
  image->V = mesh.V;
  record_connectivity(*image, mesh);
  image->extra = std::move(extra);
  mesh.image = std::move(image);
}

std::vector<double> point_displacements(const Mesh& mesh, const std::vector<int>& vertex_of_point) {
  std::vector<double> d(3 * vertex_of_point.size());
  for (std::size_t p = 0; p < vertex_of_point.size(); ++p)
    for (int a = 0; a < 3; ++a)
      d[3 * p + a] = mesh.V(vertex_of_point[p], a) - mesh.image->V(vertex_of_point[p], a);
  return d;
}

}  // namespace detail

const char* format_name(FileFormat format) {
  return enum_name(format);
}

const char* encoding_name(Encoding encoding) {
  return enum_name(encoding);
}

FileFormat format_from_path(const std::string& path) {
  const std::string ext = std::filesystem::path(path).extension().string();
  for (const NamedValue<FileFormat>& f : EnumTable<FileFormat>::values)
    if (ext.size() > 1 && detail::same_name(std::string_view(ext).substr(1), f.name))
      return f.value;
  std::vector<std::string> expected;
  for (const std::string_view name : enum_names<FileFormat>())
    expected.push_back(fmt::format(".{}", name));
  throw InvalidArgumentError(fmt::format("{}: unknown mesh extension '{}' (expected {})", path, ext,
                                         fmt::join(expected, ", ")));
}

namespace {

// Closes a file descriptor on every path out of a scope.
struct FileDescriptor {
  int fd = -1;
  ~FileDescriptor() {
    if (fd >= 0) ::close(fd);
  }
};

const char* file_kind(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

std::string size_text(std::size_t bytes) {
  if (bytes % (1u << 20) == 0) return fmt::format("{} MiB", bytes >> 20);
  return fmt::format("{} bytes", bytes);
}

}  // namespace

std::string read_file(const std::string& path) {
  return read_file(path, std::numeric_limits<std::size_t>::max(), "file");
}

std::string read_file(const std::string& path, std::size_t max_bytes, std::string_view what) {
  // O_NONBLOCK: opening a FIFO must not wait for a writer; fstat then refuses it.
  FileDescriptor file{::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC)};
  if (file.fd < 0)
    throw ReadError(
        fmt::format("{}: cannot open the {} for reading: {}", path, what, std::strerror(errno)));
  struct stat st {};
  if (::fstat(file.fd, &st) != 0)
    throw ReadError(fmt::format("{}: cannot read the {}: {}", path, what, std::strerror(errno)));
  if (!S_ISREG(st.st_mode))
    throw ReadError(fmt::format("{}: the {} is {}; only regular files are read", path, what,
                                file_kind(st.st_mode)));
  auto too_large = [&] {
    return ReadError(fmt::format("{}: the {} is larger than {}, the most it may hold", path, what,
                                 size_text(max_bytes)));
  };
  if (static_cast<std::uint64_t>(st.st_size) > max_bytes) throw too_large();
  std::string bytes(static_cast<std::size_t>(st.st_size), '\0');
  std::size_t done = 0;
  char chunk[1 << 16];
  while (true) {
    // Up to the size fstat gave straight into place; past it (the file grew, or reports no
    // size as /proc files do) in chunks, within the limit.
    const bool within = done < bytes.size();
    const ssize_t n = within ? ::read(file.fd, bytes.data() + done, bytes.size() - done)
                             : ::read(file.fd, chunk, sizeof chunk);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw ReadError(fmt::format("{}: read error: {}", path, std::strerror(errno)));
    if (n == 0) break;
    if (!within) {
      if (static_cast<std::size_t>(n) > max_bytes - done) throw too_large();
      bytes.append(chunk, static_cast<std::size_t>(n));
    }
    done += static_cast<std::size_t>(n);
  }
  bytes.resize(done);
  return bytes;
}

namespace {
void check_weld_tolerance(const ReadOptions& options) {
  if (!(options.weld_tolerance >= 0) || !std::isfinite(options.weld_tolerance))
    throw InvalidArgumentError(fmt::format(
        "weld tolerance {} is not a finite non-negative distance", options.weld_tolerance));
}
}  // namespace

Mesh read_mesh_from_bytes(std::string bytes, FileFormat format, const std::string& name,
                          const ReadOptions& options) {
  check_weld_tolerance(options);
  switch (format) {
    case FileFormat::Off:
      return detail::read_off(bytes, options.keep_image ? &bytes : nullptr, name, options);
    case FileFormat::Obj:
      return detail::read_obj(bytes, options.keep_image ? &bytes : nullptr, name, options);
    case FileFormat::Ply:
      return detail::read_ply(bytes, options.keep_image ? &bytes : nullptr, name, options);
    case FileFormat::Stl:
      return detail::read_stl(bytes, options.keep_image ? &bytes : nullptr, name, options);
    case FileFormat::Gltf:
    case FileFormat::Glb:
      return detail::read_gltf(std::move(bytes), format, name, options);
    case FileFormat::Draco:
      return detail::read_draco(bytes, name, options);
    case FileFormat::ThreeMf:
      return detail::read_3mf(std::move(bytes), name, options);
  }
  throw InvalidArgumentError("unknown format");
}

Mesh read_mesh_from_buffer(const std::string& bytes, FileFormat format, const std::string& name,
                           const ReadOptions& options) {
  check_weld_tolerance(options);
  ReadOptions ro = options;
  ro.keep_image = false;
  switch (format) {
    case FileFormat::Off:
      return detail::read_off(bytes, nullptr, name, ro);
    case FileFormat::Obj:
      return detail::read_obj(bytes, nullptr, name, ro);
    case FileFormat::Ply:
      return detail::read_ply(bytes, nullptr, name, ro);
    case FileFormat::Stl:
      return detail::read_stl(bytes, nullptr, name, ro);
    default:
      return read_mesh_from_bytes(bytes, format, name, ro);
  }
}

Mesh read_mesh(const std::string& path, const ReadOptions& options) {
  const FileFormat format = format_from_path(path);
  return read_mesh_from_bytes(read_file(path), format, path, options);
}

namespace {

// Refuses positions that a float32 output would turn into infinities (unreadable, even by us).
void check_fits_float32(const Mesh& mesh, const char* stored_as) {
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i)
    for (int a = 0; a < 3; ++a)
      if (std::isinf(static_cast<float>(mesh.V(i, a))))
        throw InvalidArgumentError(fmt::format(
            "{}: coordinates do not fit in float32, which {} stores (vertex {}: {} = {}; float32 "
            "reaches about 3.4e38)",
            mesh.source_path.empty() ? "the mesh" : mesh.source_path, stored_as, i, "xyz"[a],
            mesh.V(i, a)));
}

bool has_float32_slots(const FileImage& image) {
  if (image.regular)
    for (const SlotType t : image.regular->type)
      if (t == SlotType::Float32) return true;
  return std::any_of(image.slots.begin(), image.slots.end(),
                     [](const CoordSlot& s) { return s.type == SlotType::Float32; });
}

}  // namespace

std::string write_mesh_to_bytes(const Mesh& mesh, FileFormat format, const WriteOptions& options) {
  switch (format) {  // formats whose writers own their images
    case FileFormat::Gltf:
    case FileFormat::Glb:
      return detail::write_gltf(mesh, format, options, {}, nullptr);
    case FileFormat::Draco:
      return detail::write_draco(mesh, options);
    case FileFormat::ThreeMf:
      return detail::write_3mf(mesh, options);
    default:
      break;
  }
  Encoding encoding = Encoding::Ascii;
  if (format == FileFormat::Ply || format == FileFormat::Stl)
    encoding = options.encoding.value_or(mesh.format == format ? mesh.encoding
                                                               : Encoding::BinaryLittleEndian);
  if (format == FileFormat::Stl && encoding == Encoding::BinaryBigEndian)
    throw InvalidArgumentError("STL has no big-endian encoding");
  if (options.vertex_colors && options.vertex_colors->rows() != mesh.V.rows())
    throw InvalidArgumentError(fmt::format("{} vertex colors for {} vertices",
                                           options.vertex_colors->rows(), mesh.V.rows()));
  if (options.keep_source && !options.single_precision && !options.vertex_colors &&
      detail::image_applies(mesh, format, encoding)) {
    if (has_float32_slots(*mesh.image)) check_fits_float32(mesh, "the source file");
    return detail::patch_image(*mesh.image, mesh);
  }
  if (format == FileFormat::Stl && encoding != Encoding::Ascii)
    check_fits_float32(mesh, "binary STL");
  if (format == FileFormat::Ply && options.single_precision)
    check_fits_float32(mesh, "PLY with float32 coordinates");
  switch (format) {
    case FileFormat::Off:
      return detail::write_off(mesh);
    case FileFormat::Obj:
      return detail::write_obj(mesh);
    case FileFormat::Ply:
      return detail::write_ply(mesh, encoding, options.single_precision, options.vertex_colors);
    case FileFormat::Stl:
      return detail::write_stl(mesh, encoding);
    default:
      break;
  }
  throw InvalidArgumentError("unknown format");
}

MeshFiles write_mesh_files(const std::string& path, const Mesh& mesh, const WriteOptions& options) {
  validate_mesh(mesh, path);
  // The extension is looked at only when no format is given (OUT may have none).
  const FileFormat format = options.format ? *options.format : format_from_path(path);
  MeshFiles files;
  files.format = format;
  if (!mesh.source_path.empty()) files.inputs.push_back(mesh.source_path);
  for (std::string& p : detail::gltf_source_files(mesh)) files.inputs.push_back(std::move(p));
  if (format == FileFormat::Gltf)
    files.bytes = detail::write_gltf(mesh, format, options,
                                     std::filesystem::path(path).stem().string(), &files.resources);
  else
    files.bytes = write_mesh_to_bytes(mesh, format, options);
  return files;
}

void write_mesh_files_atomically(const std::string& path, const MeshFiles& files) {
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  std::vector<std::string> targets;
  for (const auto& entry : files.resources) targets.push_back((folder / entry.first).string());
  targets.push_back(path);
  for (const std::string& target : targets) {
    std::error_code ec;
    for (const std::string& input : files.inputs)
      if (std::filesystem::equivalent(target, input, ec))
        throw InvalidArgumentError(
            fmt::format("{}: refusing to overwrite {}, which the mesh was read from",
                        printable(target), printable(input)));
    struct stat st {};
    if (::lstat(target.c_str(), &st) == 0 && !S_ISREG(st.st_mode))
      throw WriteError(fmt::format("{}: not a regular file; meshmark writes regular files only",
                                   printable(target)));
  }
  for (const auto& [name, bytes] : files.resources)
    write_file_atomically((folder / name).string(), bytes);
  write_file_atomically(path, files.bytes);
}

void write_mesh(const std::string& path, const Mesh& mesh, const WriteOptions& options) {
  write_mesh_files_atomically(path, write_mesh_files(path, mesh, options));
}

namespace {

// A write to TARGET goes through ".TARGET.meshmark-PID-XXXXXX" in TARGET's folder: PID is the
// writing process, XXXXXX six random letters or digits.
constexpr std::size_t kRandomChars = 6;

bool is_alnum(char c) {
  return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z');
}

// The PID in name when name is exactly prefix + PID + '-' + six letters or digits; 0 otherwise.
pid_t temporary_owner(std::string_view name, std::string_view prefix) {
  if (!name.starts_with(prefix)) return 0;
  name.remove_prefix(prefix.size());
  const std::size_t dash = name.find('-');
  if (dash == std::string_view::npos || dash == 0 || dash > 9 ||
      name.size() != dash + 1 + kRandomChars)
    return 0;
  std::int64_t pid = 0;
  for (const char c : name.substr(0, dash)) {
    if (c < '0' || c > '9') return 0;
    pid = 10 * pid + (c - '0');
  }
  for (const char c : name.substr(dash + 1))
    if (!is_alnum(c)) return 0;
  return pid > 0 && pid <= std::numeric_limits<pid_t>::max() ? static_cast<pid_t>(pid) : 0;
}

// Removes what writers to the same target left when killed before their rename: regular files
// of exactly our naming pattern whose PID names no running process.
void remove_stale_temporaries(const std::string& dir, const std::string& prefix) {
  DIR* d = ::opendir(dir.c_str());
  if (!d) return;
  while (const dirent* entry = ::readdir(d)) {
    const pid_t pid = temporary_owner(entry->d_name, prefix);
    if (pid == 0 || pid == ::getpid()) continue;
    if (::kill(pid, 0) == 0 || errno != ESRCH) continue;  // running, or another user's
    const std::string stale = dir + "/" + entry->d_name;
    struct stat st {};
    if (::lstat(stale.c_str(), &st) == 0 && S_ISREG(st.st_mode)) ::unlink(stale.c_str());
  }
  ::closedir(d);
}

// Creates a new temporary file for writing with the given mode (the kernel applies the umask).
int create_temporary(const std::string& dir, const std::string& prefix, mode_t mode,
                     std::string& name) {
  static constexpr char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789";
  std::random_device random;
  for (int attempt = 0; attempt < 100; ++attempt) {
    name = fmt::format("{}/{}{}-", dir, prefix, ::getpid());
    for (std::size_t k = 0; k < kRandomChars; ++k) name += kAlphabet[random() % 62];
    const int fd = ::open(name.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, mode);
    if (fd >= 0 || errno != EEXIST) return fd;
  }
  return -1;
}

// Gives the new file an existing target's permission bits, and its owner and group where the
// system allows; a group that cannot be kept loses its access rather than pass it to ours.
bool keep_mode(int fd, const struct stat& old) {
  mode_t mode = old.st_mode & 0777;
  struct stat now {};
  if (::fstat(fd, &now) != 0) return false;
  if ((now.st_uid != old.st_uid || now.st_gid != old.st_gid) &&
      ::fchown(fd, old.st_uid, old.st_gid) != 0 && ::fchown(fd, -1, old.st_gid) != 0)
    mode &= ~static_cast<mode_t>(070);
  return ::fchmod(fd, mode) == 0;
}

bool write_all(int fd, const std::string& bytes) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    done += static_cast<std::size_t>(n);
  }
  return true;
}

}  // namespace

void write_file_atomically(const std::string& path, const std::string& bytes) {
  const std::filesystem::path target(path);
  std::string dir = target.parent_path().string();
  if (dir.empty()) dir = ".";
  const std::string prefix = "." + target.filename().string() + ".meshmark-";
  remove_stale_temporaries(dir, prefix);
  // Only a regular file is replaced: renaming over a device, a FIFO, a socket or a symbolic
  // link would destroy it (as root, /dev/null itself) instead of writing to what it names.
  struct stat link {};
  if (::lstat(path.c_str(), &link) == 0 && !S_ISREG(link.st_mode))
    throw WriteError(fmt::format("{}: not a regular file ({}); meshmark writes regular files only",
                                 path,
                                 S_ISLNK(link.st_mode)    ? "a symbolic link"
                                 : S_ISDIR(link.st_mode)  ? "a directory"
                                 : S_ISFIFO(link.st_mode) ? "a FIFO"
                                 : S_ISCHR(link.st_mode) || S_ISBLK(link.st_mode) ? "a device"
                                                                                  : "a socket"));
  // A new file gets 0666 less the umask; an existing one keeps its mode (created no wider).
  struct stat old {};
  const bool existing = ::stat(path.c_str(), &old) == 0 && S_ISREG(old.st_mode);
  std::string tmp;
  const int fd = create_temporary(dir, prefix, existing ? old.st_mode & 0777 : 0666, tmp);
  if (fd < 0)
    throw WriteError(fmt::format("{}: cannot create a temporary file in {}: {}", path, dir,
                                 std::strerror(errno)));
  auto fail_with = [&](const char* what, int err) {
    ::close(fd);
    ::unlink(tmp.c_str());
    throw WriteError(fmt::format("{}: {}: {}", path, what, std::strerror(err)));
  };
  if (!write_all(fd, bytes)) fail_with("write failed", errno);
  if (existing && !keep_mode(fd, old)) fail_with("cannot keep the file's mode", errno);
  if (::fsync(fd) != 0) fail_with("write failed", errno);
  if (::close(fd) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    throw WriteError(fmt::format("{}: write failed: {}", path, std::strerror(err)));
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    throw WriteError(fmt::format("{}: cannot rename the temporary file into place: {}", path,
                                 std::strerror(err)));
  }
}

}  // namespace meshmark
