// meshmark serve --listen HOST:PORT --registry DB --key-file K: an HTTP/JSON issuer and tracer
// for a marketplace (docs/serving.md). The library's Issuer holds the prepared originals and
// every rule; this file parses requests and prints answers.

#include <fmt/format.h>
#include <sodium.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <thread>

#include "cli.h"
#include "meshmark/core/error.h"
#include "meshmark/forensics/trace_files.h"
#include "meshmark/version.h"

// After Eigen's headers (cli.h): <resolv.h>, which httplib.h includes, defines _res.
#include <httplib.h>

namespace meshmark::cli {

namespace {

namespace fs = std::filesystem;

struct ServeArgs {
  std::string listen = "127.0.0.1:8080", registry, token_file;
  KeyArgs keys;
  InputOptions in;
  std::size_t originals = 16;
  double max_upload_mib = 512;
  double strength = 0.05;
  bool fingerprint = false;     // --fingerprint
  bool no_fingerprint = false;  // --no-fingerprint
};

// The formats a copy may be asked in, with their content types.
const std::map<std::string, std::string>& copy_formats() {
  static const std::map<std::string, std::string> formats = {{"ply", "application/octet-stream"},
                                                             {"obj", "model/obj"},
                                                             {"off", "text/plain"},
                                                             {"stl", "model/stl"},
                                                             {"glb", "model/gltf-binary"},
                                                             {"3mf", "model/3mf"},
                                                             {"drc", "application/octet-stream"}};
  return formats;
}

// An error answer: {"error": message} with the status.
void answer_error(httplib::Response& res, int status, const std::string& message) {
  res.status = status;
  res.set_content(nlohmann::json{{"error", printable(message)}}.dump(), "application/json");
}

void answer_json(httplib::Response& res, const nlohmann::json& j, int status = 200) {
  res.status = status;
  res.set_content(j.dump(2), "application/json");
}

// The status of an exception the library threw while serving a request.
int status_of(const std::exception& e) {
  if (dynamic_cast<const InvalidInputError*>(&e) || dynamic_cast<const ReadError*>(&e) ||
      dynamic_cast<const InvalidArgumentError*>(&e))
    return 400;
  return 500;
}

// The HTTP status of a copy that was not issued.
int status_of(CopyStatus status) {
  switch (status) {
    case CopyStatus::Refused:
      return 409;  // the registry's refusals: an ID taken, too close, reserved
    case CopyStatus::Unreadable:
      return 400;
    case CopyStatus::NotEmbedded:
    case CopyStatus::NotWithinFidelity:
    case CopyStatus::NotCarried:
      return 422;
    default:
      return 500;
  }
}

// The bearer token, from --token-file or MESHMARK_TOKEN.
std::string read_token(const ServeArgs& a) {
  std::string token;
  if (!a.token_file.empty()) {
    token = read_file(a.token_file);
    while (!token.empty() && (token.back() == '\n' || token.back() == '\r')) token.pop_back();
  } else if (const char* env = std::getenv("MESHMARK_TOKEN")) {
    token = env;
  }
  if (token.size() < 16)
    throw InvalidArgumentError(
        token.empty() ? "serve needs a bearer token: set MESHMARK_TOKEN or give --token-file"
                      : "the bearer token has fewer than 16 characters: use a longer one");
  if (token.find_first_of(" \t\r\n") != std::string::npos)
    throw InvalidArgumentError("the bearer token holds a space or a line break");
  return token;
}

// A request's bearer token is the server's (a comparison in constant time).
bool authorized(const httplib::Request& req, const std::string& token) {
  const std::string header = req.get_header_value("Authorization");
  const std::string prefix = "Bearer ";
  if (header.size() != prefix.size() + token.size() || header.compare(0, prefix.size(), prefix))
    return false;
  return sodium_memcmp(header.data() + prefix.size(), token.data(), token.size()) == 0;
}

// HOST:PORT, the host a name or an IPv4 address (an IPv6 one in brackets).
std::pair<std::string, int> parse_listen(const std::string& text) {
  const std::size_t colon = text.rfind(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == text.size())
    throw InvalidArgumentError(fmt::format("--listen '{}' is not HOST:PORT", text));
  std::string host = text.substr(0, colon);
  if (host.size() > 2 && host.front() == '[' && host.back() == ']')
    host = host.substr(1, host.size() - 2);
  const std::string port_text = text.substr(colon + 1);
  if (port_text.find_first_not_of("0123456789") != std::string::npos || port_text.size() > 5 ||
      std::stoi(port_text) > 65535)
    throw InvalidArgumentError(fmt::format("--listen '{}': the port is not 0..65535", text));
  return {host, std::stoi(port_text)};
}

// This machine's name, for the server's temporary folder.
std::string host_name() {
  char name[256] = {};
  if (gethostname(name, sizeof name - 1) != 0) return "host";
  std::string out = name;
  for (char& c : out)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-') c = '_';
  return out;
}

// The prefix of a server's temporary folder: meshmark-serve-HOST-PID-.
std::string work_prefix(pid_t pid) {
  return fmt::format("meshmark-serve-{}-{}-", host_name(), pid);
}

// Gives back the rows that servers killed on this machine had reserved: copies being made
// whose answers were never sent (a reserved row names its output, in the server's temporary
// folder, which holds the machine and the process). Their folders are removed. The rows of a
// server still running, here or on another machine, are left alone.
std::size_t release_dead_servers_rows(Registry& registry, const Key& key) {
  RegistryQuery q;
  q.state = "reserved";
  q.key_fingerprint = key_fingerprint(key);
  const std::string here = fmt::format("meshmark-serve-{}-", host_name());
  std::vector<IssuedCopy> dead;
  std::set<fs::path> folders;
  for (const IssuedCopy& c : registry.list(q)) {
    const fs::path folder = fs::path(c.output_path).parent_path();
    const std::string name = folder.filename().string();
    if (name.rfind(here, 0) != 0) continue;
    const std::string rest = name.substr(here.size());
    const std::size_t dash = rest.find('-');
    if (dash == std::string::npos || dash == 0) continue;
    const pid_t pid = static_cast<pid_t>(std::strtol(rest.substr(0, dash).c_str(), nullptr, 10));
    if (pid <= 0 || kill(pid, 0) == 0 || errno != ESRCH) continue;  // alive, or not ours to say
    dead.push_back(c), folders.insert(folder);
  }
  registry.release(dead);
  std::error_code ec;
  for (const fs::path& f : folders) fs::remove_all(f, ec);
  return dead.size();
}

// A temporary folder of the server's own, removed when it stops.
class WorkDir {
 public:
  WorkDir() {
    std::string pattern = (fs::temp_directory_path() / (work_prefix(getpid()) + "XXXXXX")).string();
    if (!mkdtemp(pattern.data()))
      throw IOError(fmt::format("{}: cannot make the server's temporary folder", pattern));
    path_ = pattern;
  }
  ~WorkDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  WorkDir(const WorkDir&) = delete;
  WorkDir& operator=(const WorkDir&) = delete;
  // A new file name in the folder with this extension (".ply").
  std::string file(const std::string& what, const std::string& extension) {
    return (path_ / fmt::format("{}-{}{}", what, ++count_, extension)).string();
  }

 private:
  fs::path path_;
  std::atomic<std::uint64_t> count_{0};
};

// An uploaded mesh, read through a temporary file named with the upload's extension (the
// format's only sign); errors name the upload, not the temporary file.
Mesh read_upload(const httplib::MultipartFormData& upload, WorkDir& work, const ReadOptions& read) {
  std::string extension = fs::path(upload.filename).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (extension.empty())
    throw InvalidArgumentError(fmt::format(
        "the upload '{}' has no file name extension: it names the format (.ply, .obj, .glb, ...)",
        upload.filename));
  const std::string path = work.file("upload", extension);
  {
    std::ofstream out(path, std::ios::binary);
    out.write(upload.content.data(), static_cast<std::streamsize>(upload.content.size()));
    if (!out) throw IOError(fmt::format("{}: cannot write the upload", path));
  }
  struct Remove {
    std::string path;
    ~Remove() { std::remove(path.c_str()); }
  } remove{path};
  try {
    return read_mesh(path, read);
  } catch (const InvalidInputError& e) {
    throw InvalidInputError(upload.filename, e.line(), e.detail());
  } catch (const Error& e) {
    std::string message = e.what();
    for (std::size_t at = message.find(path); at != std::string::npos;
         at = message.find(path, at + upload.filename.size()))
      message.replace(at, path.size(), upload.filename);
    throw ReadError(message);
  }
}

class Service {
 public:
  Service(const ServeArgs& a, IssueSettings settings, Key key)
      : args_(a), key_(std::move(key)), issuer_(std::move(settings), a.originals) {}

  void routes(httplib::Server& server, const std::string& token) {
    server.set_pre_routing_handler([token](const httplib::Request& req, httplib::Response& res) {
      if (req.path == "/health" || authorized(req, token))
        return httplib::Server::HandlerResponse::Unhandled;
      res.set_header("WWW-Authenticate", "Bearer");
      answer_error(res, 401, "a bearer token is needed (Authorization: Bearer TOKEN)");
      return httplib::Server::HandlerResponse::Handled;
    });
    // Answers the library gives without a body (no such endpoint, a body too large): JSON too.
    server.set_error_handler([](const httplib::Request&, httplib::Response& res) {
      if (!res.body.empty()) return;
      answer_error(res, res.status,
                   res.status == 404   ? "no such endpoint (GET /health, POST /originals, POST "
                                         "/copies, POST /trace, GET /copies/ID)"
                   : res.status == 413 ? "the request body is larger than --max-upload"
                                       : "the request is refused");
    });
    server.set_exception_handler(
        [](const httplib::Request&, httplib::Response& res, const std::exception_ptr& ep) {
          try {
            std::rethrow_exception(ep);
          } catch (const std::exception& e) {
            answer_error(res, status_of(e), e.what());
          } catch (...) {
            answer_error(res, 500, "unknown error");
          }
        });
    server.Get("/health", [](const httplib::Request&, httplib::Response& res) {
      answer_json(res, nlohmann::json{{"status", "ok"},
                                      {"service", "meshmark"},
                                      {"version", MESHMARK_VERSION_STRING}});
    });
    server.Post("/originals", [this](const httplib::Request& req, httplib::Response& res) {
      post_original(req, res);
    });
    server.Post("/copies", [this](const httplib::Request& req, httplib::Response& res) {
      post_copy(req, res);
    });
    server.Post("/trace", [this](const httplib::Request& req, httplib::Response& res) {
      post_trace(req, res);
    });
    server.Get(R"(/copies/(\d+))", [this](const httplib::Request& req, httplib::Response& res) {
      get_copies(req, res);
    });
  }

  Registry* registry() { return issuer_.registry(); }

 private:
  void post_original(const httplib::Request& req, httplib::Response& res) {
    if (!req.has_file("mesh"))
      return answer_error(res, 400, "POST /originals takes the mesh as the multipart field 'mesh'");
    const httplib::MultipartFormData upload = req.get_file_value("mesh");
    Mesh mesh = read_upload(upload, work_, read_options(args_.in));
    const PreparedOriginal p = issuer_.prepare(std::move(mesh), upload.filename);
    answer_json(res,
                {{"original", p.geometry},
                 {"name", p.name},
                 {"vertices", p.vertices},
                 {"faces", p.faces},
                 {"prepared_before", p.prepared_before}},
                p.prepared_before ? 200 : 201);
  }

  void post_copy(const httplib::Request& req, httplib::Response& res) {
    nlohmann::json body;
    try {
      body = nlohmann::json::parse(req.body);
    } catch (const std::exception& e) {
      return answer_error(res, 400, fmt::format("the body is not JSON: {}", e.what()));
    }
    if (!body.is_object()) return answer_error(res, 400, "the body is not a JSON object");
    for (const auto& [name, value] : body.items())
      if (name != "original" && name != "buyer" && name != "format" && name != "id")
        return answer_error(res, 400,
                            fmt::format("unknown field '{}' (original, buyer, format, "
                                        "id)",
                                        name));
    if (!body.contains("original") || !body["original"].is_string())
      return answer_error(res, 400, "'original' (the hash POST /originals answered) is needed");
    if (!body.contains("buyer") || !body["buyer"].is_string() ||
        body["buyer"].get<std::string>().empty())
      return answer_error(res, 400, "'buyer' (a non-empty label) is needed");
    const std::string format = body.value("format", std::string("ply"));
    if (!copy_formats().count(format))
      return answer_error(
          res, 400,
          fmt::format("format '{}' is not one of ply, obj, off, stl, glb, 3mf, drc", format));
    const std::optional<PreparedOriginal> original =
        issuer_.find(body["original"].get<std::string>());
    if (!original)
      return answer_error(res, 404, "no such original: POST /originals prepares it first");
    CopyRequest request;
    request.input = original->name;
    request.mesh = original->mesh;
    request.buyer = body["buyer"].get<std::string>();
    request.output = work_.file("copy", "." + format);
    if (!body.contains("id") || body["id"] == "auto") {
      request.auto_id = true;
    } else if (body["id"].is_number_unsigned()) {
      request.id = body["id"].get<std::uint64_t>();
    } else if (body["id"].is_string()) {
      set_copy_id(request, body["id"].get<std::string>());
    } else {
      return answer_error(res, 400, "'id' is a non-negative integer or \"auto\"");
    }
    const std::string output = request.output;
    const IssueResult result = issuer_.issue({request});
    const CopyOutcome& c = result.copies.at(0);
    if (c.status != CopyStatus::Written) {
      std::remove(output.c_str());
      return answer_error(res, status_of(c.status),
                          fmt::format("{}: {}", copy_status_name(c.status), c.message));
    }
    const std::string bytes = read_file(output);
    std::remove(output.c_str());
    res.set_header("X-Meshmark-Id", std::to_string(c.record.id));
    res.set_header("X-Meshmark-Row", std::to_string(c.record.row));
    res.set_header("Content-Disposition",
                   fmt::format("attachment; filename=\"copy-{}.{}\"", c.record.id, format));
    res.status = 200;
    res.set_content(bytes, copy_formats().at(format).c_str());
  }

  void post_trace(const httplib::Request& req, httplib::Response& res) {
    if (!req.has_file("leak") || !req.has_file("original"))
      return answer_error(res, 400,
                          "POST /trace takes the multipart fields 'leak' (the mesh) and "
                          "'original' (the hash POST /originals answered)");
    const std::optional<PreparedOriginal> original =
        issuer_.find(req.get_file_value("original").content);
    if (!original)
      return answer_error(res, 404, "no such original: POST /originals prepares it first");
    const httplib::MultipartFormData upload = req.get_file_value("leak");
    TraceFilesRequest request;
    request.leaked = upload.filename;
    request.original = original->name;
    request.leaked_mesh =
        std::make_shared<const Mesh>(read_upload(upload, work_, read_options(args_.in)));
    request.original_mesh = original->mesh;
    request.registry = args_.registry;
    request.read = read_options(args_.in);
    const TraceFilesResult found = trace_files(request, key_);
    std::vector<std::string> warnings = found.warnings;
    warnings.insert(warnings.end(), found.trace.warnings.begin(), found.trace.warnings.end());
    answer_json(res, trace_json(found.trace, request.options, warnings));
  }

  void get_copies(const httplib::Request& req, httplib::Response& res) {
    RegistryQuery q;
    q.id = parse_id(req.matches[1]);
    q.key_fingerprint = key_fingerprint(key_);
    nlohmann::json rows = nlohmann::json::array();
    for (const IssuedCopy& c : read_registry(args_.registry, q))
      rows.push_back(registry_row_json(c));
    if (rows.empty()) return answer_error(res, 404, fmt::format("no copy carries ID {}", *q.id));
    answer_json(res, rows);
  }

  const ServeArgs& args_;
  Key key_;
  Issuer issuer_;
  WorkDir work_;
};

int run(const ServeArgs& a) {
  const auto [host, port] = parse_listen(a.listen);
  const std::string token = read_token(a);
  const std::optional<Key> key = resolve_key_in(a.keys, a.registry);
  if (!key) throw InvalidArgumentError("serve needs the shop's key (--key-file or --key)");
  if (a.originals < 1 || a.originals > 100000)
    throw InvalidArgumentError(fmt::format("--originals {} is out of 1..100000", a.originals));
  if (!(a.max_upload_mib > 0 && a.max_upload_mib <= 65536))
    throw InvalidArgumentError(
        fmt::format("--max-upload {} MiB is out of (0, 65536]", a.max_upload_mib));
  IssueSettings settings;
  settings.key = *key;
  settings.registry = a.registry;
  settings.id_bits = a.keys.id_bits;
  settings.read = read_options(a.in);
  settings.embedding.strength = a.strength;
  if (a.fingerprint || a.no_fingerprint) settings.fingerprint = a.fingerprint;
  settings.threads = 1;  // one copy per request; requests run side by side
  Service service(a, settings, *key);
  if (Registry* registry = service.registry())
    if (const std::size_t released = release_dead_servers_rows(*registry, *key))
      fmt::print("meshmark serve: gave back {} row(s) reserved by a server that was killed\n",
                 released);
  httplib::Server server;
  server.set_payload_max_length(static_cast<std::size_t>(a.max_upload_mib * 1024 * 1024));
  service.routes(server, token);
  const int bound = port == 0                         ? server.bind_to_any_port(host)
                    : server.bind_to_port(host, port) ? port
                                                      : -1;
  if (bound < 0) throw IOError(fmt::format("cannot listen on {}", a.listen));
  // SIGINT and SIGTERM stop the server: requests under way finish, then it returns.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
  std::atomic<bool> stopped{false};
  std::thread stopper([&] {
    const timespec tick{0, 200000000};  // looks again whether the server stopped on its own
    while (!stopped)
      if (sigtimedwait(&stop_signals, nullptr, &tick) > 0) {
        server.stop();
        return;
      }
  });
  fmt::print("meshmark serve: listening on http://{}:{} (registry {})\n",
             host.find(':') != std::string::npos ? "[" + host + "]" : host, bound,
             registry_display_name(a.registry));
  std::fflush(stdout);
  const bool ok = server.listen_after_bind();
  stopped = true;
  stopper.join();
  fmt::print("meshmark serve: stopped\n");
  return ok ? kOk : kWriteFailed;
}

}  // namespace

void register_serve(CLI::App& app, int& exit_code) {
  auto args = std::make_shared<ServeArgs>();
  CLI::App* sub = app.add_subcommand(
      "serve", "Issue and trace copies over HTTP/JSON for a marketplace (docs/serving.md)");
  sub->add_option("--listen", args->listen, "HOST:PORT to listen on (port 0: any free one)")
      ->capture_default_str();
  sub->add_option("--registry", args->registry, "the registry (SQLite file or postgresql:// URI)")
      ->required();
  sub->add_option("--token-file", args->token_file,
                  "the bearer token every request but GET /health needs (else MESHMARK_TOKEN)");
  sub->add_option("--originals", args->originals, "prepared originals held at most")
      ->capture_default_str();
  sub->add_option("--max-upload", args->max_upload_mib, "largest request body, in MiB")
      ->capture_default_str();
  sub->add_option("--strength", args->strength, "the mark's strength alpha")->capture_default_str();
  CLI::Option* fingerprint =
      sub->add_flag("--fingerprint", args->fingerprint,
                    "every copy carries the buyer's fingerprint: an original too small for one "
                    "is refused (by default, copies of such an original are issued without; "
                    "docs/forensics.md)");
  sub->add_flag("--no-fingerprint", args->no_fingerprint,
                "no copy carries the fingerprint (only the histogram mark)")
      ->excludes(fingerprint);
  add_key_options(*sub, args->keys);
  add_input_options(*sub, args->in);
  sub->callback([args, &exit_code] { exit_code = run(*args); });
}

}  // namespace meshmark::cli
