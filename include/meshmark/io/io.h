#pragma once
/// \file io.h
/// Reading and writing OFF, OBJ, PLY (ascii, binary little and big endian; face lists and
/// triangle strips) and STL (ascii and binary), one dispatcher over per-format readers.
///
/// A read keeps an image of the file, so that writing the mesh back in the same format changes
/// vertex positions and nothing else: OBJ texture coordinates, normals, groups, materials,
/// comments and face index style; every other PLY element and property; STL triangle order,
/// normals and attribute bytes. Coordinates whose value did not change keep their bytes.
/// Text formats are written with round-trip precision (shortest representation that reads
/// back to the same double).
///
/// Draco (.drc) and 3MF (.3mf) are read through libdraco and lib3mf, bit-identical positions
/// welded (Draco splits vertices at seams; 3MF places objects in world space); writing back
/// re-encodes the source with every point or object vertex moved by its vertex's displacement
/// and everything else those libraries keep (see io_formats.h for what Draco's quantization
/// and lib3mf's writer change).

#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "meshmark/core/mesh.h"

namespace meshmark {

/// Options of read_mesh.
struct ReadOptions {
  /// Referenced positions closer than this (absolute, in model units; finite, >= 0) are
  /// welded into one vertex for the computations, in every format; writing back in the same
  /// format and encoding still patches each stored coordinate (by its vertex's displacement)
  /// and keeps the file's own vertices. STL corners are always welded, bit-identical ones at
  /// 0; the other formats weld nothing at 0. Unreferenced vertices are never welded.
  /// \throw InvalidArgumentError (from the readers) when not finite or negative.
  double weld_tolerance = 0.0;
  /// Keep the file image for faithful writing (costs the file's size in memory, less a binary
  /// PLY's vertex records of x, y and z alone and face records of one index list alone, plus 16
  /// bytes for each stored coordinate of an OFF, OBJ, ASCII PLY, STL or glTF file, none for a
  /// binary PLY whose vertex records have a fixed size read without welding, plus 24 bytes a vertex
  /// for a welded file or a glTF, 3MF or Draco one). Without it, the OFF, OBJ and PLY readers
  /// record no coordinate slots.
  bool keep_image = true;
  /// glTF: external buffers by their uri (percent-decoded), consulted before the disk (to read
  /// back files not yet written, see MeshFiles). Not owned; null for none.
  const std::map<std::string, std::string>* resources = nullptr;
};

/// Reads a mesh, choosing the format from the extension (.off .obj .ply .stl, any case).
/// \throw ReadError (an IOError) when the file cannot be opened or read.
/// \throw InvalidInputError naming file, line or element, and the problem, for malformed
///        content: truncated data, wrong counts, indices out of range, NaN or infinite
///        coordinates, non-numeric tokens, no faces.
Mesh read_mesh(const std::string& path, const ReadOptions& options = {});

/// Parses a mesh from bytes already in memory; `name` is used in error messages only.
Mesh read_mesh_from_bytes(std::string bytes, FileFormat format, const std::string& name,
                          const ReadOptions& options = {});

/// read_mesh_from_bytes without an image (options.keep_image is taken as false) and, for OFF,
/// OBJ, PLY and STL, without a copy of bytes: they are parsed where they are (glTF, GLB, Draco
/// and 3MF from a copy). What embed reads its own output back with before writing it.
/// \throw as read_mesh_from_bytes.
Mesh read_mesh_from_buffer(const std::string& bytes, FileFormat format, const std::string& name,
                           const ReadOptions& options = {});

/// Options of write_mesh.
struct WriteOptions {
  /// Output format; default: from the output path's extension.
  std::optional<FileFormat> format;
  /// Output encoding; default: the source's when the format is the source's, otherwise
  /// binary little endian for PLY and STL. Ignored for OFF and OBJ (always ascii).
  std::optional<Encoding> encoding;
  /// PLY and STL binary written from scratch: store coordinates as float32 (STL always does).
  bool single_precision = false;
  /// Use the file image when it applies (same format, encoding, vertex count and faces).
  bool keep_source = true;
  /// glTF written back: quantized POSITION accessors (KHR_mesh_quantization) are stored as
  /// float32 in a new buffer view appended to their buffer (the accessor's bufferView,
  /// byteOffset, componentType, normalized and min/max rewritten; the old view stays, unused),
  /// so the mark is not requantized; KHR_mesh_quantization is removed from extensionsUsed and
  /// extensionsRequired when every vertex attribute is then float. Draco primitives and float
  /// accessors are unaffected.
  bool float_positions = false;
  /// PLY only: per-vertex colors (#V x 3, 0-255) written as red, green, blue uchar properties
  /// (the mesh is then written from scratch). Not owned; null for none.
  const Eigen::Matrix<std::uint8_t, Eigen::Dynamic, 3>* vertex_colors = nullptr;
};

/// Writes a mesh atomically (see write_file_atomically). On failure the destination is
/// untouched. The path's extension is consulted only when options.format is unset.
/// \throw WriteError (an IOError) when the file cannot be written; InvalidArgumentError for an
///        unknown extension or a mesh that breaks mesh.h's preconditions (validate_mesh).
void write_mesh(const std::string& path, const Mesh& mesh, const WriteOptions& options = {});

/// A mesh file as a write produces it, and the files it names beside it (a .gltf's external
/// buffers, named after the output: OUT.bin, or OUT_k.bin for buffer k when there are several).
struct MeshFiles {
  FileFormat format = FileFormat::Obj;
  std::string bytes;                             ///< the file itself
  std::map<std::string, std::string> resources;  ///< file name (beside it) -> bytes
  /// The files the mesh was read from (the source and its external buffers): never written.
  std::vector<std::string> inputs;
};

/// What write_mesh would write to path (without touching the disk).
MeshFiles write_mesh_files(const std::string& path, const Mesh& mesh,
                           const WriteOptions& options = {});

/// Writes the resources, then the file, each atomically (write_file_atomically), after
/// checking every target first: none may be one of files.inputs (InvalidArgumentError) or
/// exist as anything but a regular file (IOError), so a refusal writes nothing. Two writers of
/// the same .gltf at once may still pair one's file with the other's buffer: the pair is not
/// one atomic rename.
void write_mesh_files_atomically(const std::string& path, const MeshFiles& files);

/// The bytes write_mesh would write (without touching the disk); a .gltf's external buffers
/// are embedded as base64 data URIs here.
std::string write_mesh_to_bytes(const Mesh& mesh, FileFormat format,
                                const WriteOptions& options = {});

/// The format an extension names. \throw InvalidArgumentError when it names none.
FileFormat format_from_path(const std::string& path);

/// "off", "obj", "ply", "stl".
const char* format_name(FileFormat format);

/// "ascii", "binary_little_endian", "binary_big_endian".
const char* encoding_name(Encoding encoding);

/// Writes bytes to path atomically: to ".NAME.meshmark-PID-XXXXXX" in the same folder (PID
/// this process), then renamed over path. A new file gets mode 0666 less the umask; an existing
/// one keeps its permission bits (and its owner and group where the system allows). Before
/// writing, temporary files of this exact pattern for the same path whose PID names no
/// running process (left by a writer killed before its rename) are removed.
/// \throw WriteError (an IOError) on failure; the destination is then untouched.
void write_file_atomically(const std::string& path, const std::string& bytes);

/// Reads a whole regular file (symbolic links are followed). \throw ReadError when it cannot be
/// opened or read, or is not a regular file (a directory, a FIFO, a device, a socket): such
/// a file is refused without reading from it or waiting on it.
std::string read_file(const std::string& path);

/// read_file of at most max_bytes; `what` names the file in messages ("key file").
/// \throw ReadError as read_file does, and when the file holds more than max_bytes.
std::string read_file(const std::string& path, std::size_t max_bytes, std::string_view what);

}  // namespace meshmark
