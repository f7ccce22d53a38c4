#include "msspr_core/checkpoint.h"

#include <yaml-cpp/yaml.h>
#include <zlib.h>

#include <cstdio>
#include <cstring>
#include <fstream>
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

}  // namespace

std::string CheckpointHeaderToYaml(const CheckpointHeader& h) {
  YAML::Emitter out;
  out << YAML::BeginMap;
  out << YAML::Key << "step" << YAML::Value << h.step;
  std::ostringstream credit;
  credit.precision(17);
  credit << h.repr_credit;
  out << YAML::Key << "repr_credit" << YAML::Value << credit.str();
  out << YAML::Key << "sampler_rng" << YAML::Value << h.sampler_rng;
  out << YAML::Key << "options" << YAML::Value << YAML::Literal << OptionsToYaml(h.options);
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
    h.options = ApplyOptionsYaml(root["options"].as<std::string>(), MsprOptions(),
                                 path + " (checkpoint header)");
  } catch (const YAML::Exception& e) {
    Fail(path, std::string("bad checkpoint header: ") + e.what());
  } catch (const OptionsError& e) {
    Fail(path, std::string("bad options in checkpoint header: ") + e.what());
  }
  return h;
}

void WriteCheckpointFile(const std::string& path, const CheckpointFile& file) {
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

  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) Fail(path, "cannot open '" + tmp + "' for writing");
    out.write(head.data(), head.size());
    out.write(len.data(), len.size());
    out.write(file.payload.data(), file.payload.size());
    out.write(tail.data(), tail.size());
    out.flush();
    if (!out) {
      std::remove(tmp.c_str());
      Fail(path, "write failed (disk full?)");
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    Fail(path, "cannot rename '" + tmp + "' to it");
  }
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
