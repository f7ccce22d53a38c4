#include "msspr_core/checkpoint.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>
#include <zlib.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <random>
#include <sstream>

namespace msspr {
namespace core {
namespace {

constexpr char kMagic[8] = {'M', 'S', 'S', 'P', 'R', 'C', 'K', 'P'};

template <class T>
void PutLE(std::string* out, T v) {
  for (size_t i = 0; i < sizeof(T); ++i) out->push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}

template <class T>
bool GetLE(const std::string& in, size_t* pos, T* v) {
  if (*pos + sizeof(T) > in.size()) return false;
  T r = 0;
  for (size_t i = 0; i < sizeof(T); ++i) {
    r |= static_cast<T>(static_cast<unsigned char>(in[*pos + i])) << (8 * i);
  }
  *pos += sizeof(T);
  *v = r;
  return true;
}

uint32_t Crc(const std::string& a, const std::string& b) {
  uLong crc = crc32(0L, Z_NULL, 0);
  // zlib takes uInt lengths: feed in 1 GB pieces.
  for (const std::string* s : {&a, &b}) {
    size_t done = 0;
    while (done < s->size()) {
      const size_t n = std::min<size_t>(s->size() - done, size_t{1} << 30);
      crc = crc32(crc, reinterpret_cast<const Bytef*>(s->data() + done), static_cast<uInt>(n));
      done += n;
    }
  }
  return static_cast<uint32_t>(crc);
}

[[noreturn]] void Fail(const std::string& path, const std::string& what) {
  throw CheckpointError(path + ": " + what);
}

std::string Errno() { return std::strerror(errno); }

// Writes all of `data` to fd; false on error.
bool WriteAll(int fd, const char* data, size_t n) {
  while (n > 0) {
    const ssize_t w = ::write(fd, data, n);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) return false;
    data += w;
    n -= static_cast<size_t>(w);
  }
  return true;
}

// Test hook (fault injection): MSSPR_FAULT_KILL_IN_CHECKPOINT=K makes the
// K-th checkpoint write of this process SIGKILL itself halfway through the
// temporary file, as a power cut or an OOM kill would.
bool KillNow() {
  static int writes = 0;
  const char* k = std::getenv("MSSPR_FAULT_KILL_IN_CHECKPOINT");
  return k != nullptr && ++writes == std::atoi(k);
}

void SyncDirectory(const std::string& path) {
  std::string dir = std::filesystem::path(path).parent_path().string();
  if (dir.empty()) dir = ".";
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

// Removes "<name>.tmp.*" files that killed writers left beside `path`.
void RemoveStaleTemporaries(const std::string& path) {
  namespace fs = std::filesystem;
  const fs::path p(path);
  const std::string prefix = p.filename().string() + ".tmp.";
  std::error_code ec;
  const fs::path dir = p.parent_path().empty() ? fs::path(".") : p.parent_path();
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    if (it->path().filename().string().rfind(prefix, 0) == 0) fs::remove(it->path(), ec);
  }
}

std::map<std::string, std::string>& ProcessMetadata() {
  static std::map<std::string, std::string> m;
  return m;
}

}  // namespace

void SetCheckpointMetadata(const std::string& key, const std::string& value) {
  if (value.empty())
    ProcessMetadata().erase(key);
  else
    ProcessMetadata()[key] = value;
}

std::string CheckpointHeaderToYaml(const CheckpointHeader& h) {
  YAML::Emitter out;
  out << YAML::BeginMap;
  out << YAML::Key << "step" << YAML::Value << h.step;
  std::ostringstream credit;
  credit.precision(17);
  credit << h.repr_credit;
  out << YAML::Key << "repr_credit" << YAML::Value << credit.str();
  out << YAML::Key << "sampler_rng" << YAML::Value << h.sampler_rng;
  if (!h.rank_states.empty()) {
    out << YAML::Key << "rank_states" << YAML::Value << YAML::BeginSeq;
    for (const std::string& r : h.rank_states) out << r;
    out << YAML::EndSeq;
  }
  out << YAML::Key << "options" << YAML::Value << YAML::Literal << OptionsToYaml(h.options);
  std::map<std::string, std::string> metadata = ProcessMetadata();
  for (const auto& [k, v] : h.metadata) metadata[k] = v;
  if (!metadata.empty()) {
    out << YAML::Key << "metadata" << YAML::Value << YAML::BeginMap;
    for (const auto& [k, v] : metadata) out << YAML::Key << k << YAML::Value << YAML::Literal << v;
    out << YAML::EndMap;
  }
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

CheckpointHeader ParseCheckpointHeader(const std::string& yaml, const std::string& path) {
  CheckpointHeader h;
  try {
    const YAML::Node root = YAML::Load(yaml);
    if (!root.IsMap() || !root["options"]) Fail(path, "checkpoint header has no options");
    h.step = root["step"] ? root["step"].as<int64_t>() : 0;
    h.repr_credit = root["repr_credit"] ? root["repr_credit"].as<double>() : 0.0;
    h.sampler_rng = root["sampler_rng"] ? root["sampler_rng"].as<std::string>() : "";
    if (root["rank_states"]) h.rank_states = root["rank_states"].as<std::vector<std::string>>();
    if (root["metadata"]) h.metadata = root["metadata"].as<std::map<std::string, std::string>>();
    h.options = ApplyOptionsYaml(root["options"].as<std::string>(), MsprOptions(),
                                 path + " (checkpoint header)");
  } catch (const YAML::Exception& e) {
    Fail(path, std::string("bad checkpoint header: ") + e.what());
  } catch (const OptionsError& e) {
    Fail(path, std::string("bad options in checkpoint header: ") + e.what());
  }
  return h;
}

void WriteCheckpointFile(const std::string& path, const CheckpointFile& file, bool keep_previous) {
  std::string head(kMagic, sizeof(kMagic));
  PutLE<uint32_t>(&head, kCheckpointFormatVersion);
  PutLE<uint32_t>(&head, static_cast<uint32_t>(file.kind.size()));
  head += file.kind;
  PutLE<uint64_t>(&head, file.header.size());
  head += file.header;
  std::string tail;
  PutLE<uint32_t>(&tail, Crc(file.header, file.payload));
  std::string len;
  PutLE<uint64_t>(&len, file.payload.size());

  // A unique temporary name (pid + random), so that two writers never share one.
  std::random_device rd;
  char suffix[64];
  std::snprintf(suffix, sizeof suffix, ".tmp.%ld.%08x", static_cast<long>(::getpid()), rd());
  const std::string tmp = path + suffix;
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) Fail(path, "cannot open '" + tmp + "' for writing: " + Errno());
  bool ok = WriteAll(fd, head.data(), head.size()) && WriteAll(fd, len.data(), len.size());
  if (ok && KillNow()) {
    WriteAll(fd, file.payload.data(), file.payload.size() / 2);
    ::raise(SIGKILL);
  }
  ok = ok && WriteAll(fd, file.payload.data(), file.payload.size()) &&
       WriteAll(fd, tail.data(), tail.size());
  const std::string write_error = ok ? "" : Errno();
  ok = ok && ::fsync(fd) == 0;
  const std::string sync_error = ok || !write_error.empty() ? "" : Errno();
  ::close(fd);
  if (!ok) {
    std::remove(tmp.c_str());
    Fail(path, "cannot write '" + tmp + "': " + (write_error.empty() ? sync_error : write_error) +
                   " (disk full?)");
  }
  struct stat st;
  if (keep_previous && ::stat(path.c_str(), &st) == 0) {
    // The previous file becomes <path>.prev; <path> itself stays in place until
    // the rename below replaces it, so a reader always finds a whole file.
    const std::string prev = path + ".prev", prev_tmp = prev + suffix;
    if (::link(path.c_str(), prev_tmp.c_str()) == 0) {
      if (std::rename(prev_tmp.c_str(), prev.c_str()) != 0) std::remove(prev_tmp.c_str());
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const std::string e = Errno();
    std::remove(tmp.c_str());
    Fail(path, "cannot rename '" + tmp + "' to it: " + e);
  }
  SyncDirectory(path);
  RemoveStaleTemporaries(path);
}

CheckpointFile ReadCheckpointFileOrPrevious(const std::string& path,
                                            const std::string& expected_kind,
                                            std::string* used_path) {
  try {
    CheckpointFile f = ReadCheckpointFile(path, expected_kind);
    if (used_path) *used_path = path;
    return f;
  } catch (const CheckpointError& e) {
    const std::string prev = path + ".prev";
    struct stat st;
    if (::stat(prev.c_str(), &st) != 0) throw;
    std::cerr << "msspr: " << e.what() << "; falling back to the previous checkpoint " << prev
              << "\n";
    CheckpointFile f = ReadCheckpointFile(prev, expected_kind);
    if (used_path) *used_path = prev;
    return f;
  }
}

RunDirLock::RunDirLock(const std::string& dir) : path_(dir + "/.lock") {
  fd_ = ::open(path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) throw CheckpointError(path_ + ": cannot create lock file: " + Errno());
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    const bool busy = errno == EWOULDBLOCK;
    const std::string e = Errno();
    ::close(fd_);
    fd_ = -1;
    throw CheckpointError(busy ? dir + ": another training run is using this directory (" + path_ +
                                     " is locked); wait for it to end or choose another --out"
                               : path_ + ": cannot lock: " + e);
  }
  const std::string pid = std::to_string(::getpid()) + "\n";
  if (::ftruncate(fd_, 0) == 0) WriteAll(fd_, pid.data(), pid.size());
}

RunDirLock::~RunDirLock() {
  if (fd_ >= 0) ::close(fd_);  // releases the lock (so does the end of the process)
}

CheckpointFile ReadCheckpointFile(const std::string& path, const std::string& expected_kind) {
  std::ifstream in(path, std::ios::binary);
  if (!in) Fail(path, "cannot open checkpoint");
  std::stringstream buffer;
  buffer << in.rdbuf();
  const std::string data = buffer.str();
  if (data.size() < sizeof(kMagic) || std::memcmp(data.data(), kMagic, sizeof(kMagic)) != 0) {
    Fail(path, "not an msspr checkpoint (bad magic)");
  }
  size_t pos = sizeof(kMagic);
  CheckpointFile f;
  uint32_t kind_len = 0;
  uint64_t header_len = 0, payload_len = 0;
  if (!GetLE(data, &pos, &f.version)) Fail(path, "truncated checkpoint (version)");
  if (f.version != kCheckpointFormatVersion) {
    Fail(path, "unsupported checkpoint format version " + std::to_string(f.version) +
                   " (expected " + std::to_string(kCheckpointFormatVersion) + ")");
  }
  if (!GetLE(data, &pos, &kind_len) || pos + kind_len > data.size()) {
    Fail(path, "truncated checkpoint (kind)");
  }
  f.kind = data.substr(pos, kind_len);
  pos += kind_len;
  if (!GetLE(data, &pos, &header_len) || header_len > data.size() - pos) {
    Fail(path, "truncated checkpoint (header)");
  }
  f.header = data.substr(pos, header_len);
  pos += header_len;
  if (!GetLE(data, &pos, &payload_len) || payload_len > data.size() - pos) {
    Fail(path, "truncated checkpoint (payload)");
  }
  f.payload = data.substr(pos, payload_len);
  pos += payload_len;
  uint32_t crc = 0;
  if (!GetLE(data, &pos, &crc)) Fail(path, "truncated checkpoint (checksum)");
  if (pos != data.size()) Fail(path, "trailing bytes after checkpoint");
  if (crc != Crc(f.header, f.payload)) Fail(path, "checkpoint is corrupt (checksum mismatch)");
  if (!expected_kind.empty() && f.kind != expected_kind) {
    Fail(path, "checkpoint kind is '" + f.kind + "', expected '" + expected_kind + "'");
  }
  return f;
}

}  // namespace core
}  // namespace msspr
