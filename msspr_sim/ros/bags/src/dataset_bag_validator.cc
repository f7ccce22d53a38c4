#include "msspr_bags/dataset_bag_validator.h"

#include <bzlib.h>
#include <roslz4/lz4s.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include "msspr_bags/dataset_bag.h"

namespace msspr::ros_bridge {

namespace {

class BagStructureCheck {
 public:
  explicit BagStructureCheck(const std::string& path) : path_(path) {}

  void Run() {
    f_ = std::fopen(path_.c_str(), "rb");
    if (!f_) throw BagError(path_ + ": cannot open: " + std::strerror(errno));
    std::fseek(f_, 0, SEEK_END);
    size_ = static_cast<uint64_t>(std::ftell(f_));
    std::fseek(f_, 0, SEEK_SET);
    try {
      Walk();
    } catch (...) {
      std::fclose(f_);
      throw;
    }
    std::fclose(f_);
  }

 private:
  [[noreturn]] void Fail(uint64_t at, const std::string& what) const {
    throw BagError(path_ + ": corrupt or truncated bag at byte " + std::to_string(at) + ": " +
                   what + " (a recording cut short may be repaired with 'rosbag reindex')");
  }
  void Read(uint64_t at, void* dst, uint64_t n) {
    if (at + n > size_ || std::fseek(f_, static_cast<long>(at), SEEK_SET) != 0 ||
        std::fread(dst, 1, n, f_) != n)
      Fail(at, "record runs past the end of the file");
  }
  // Parses a record header's "name=value" fields; false when the lengths do not fit.
  static bool Fields(const std::string& h, std::map<std::string, std::string>* out) {
    size_t pos = 0;
    while (pos < h.size()) {
      if (pos + 4 > h.size()) return false;
      uint32_t len;
      std::memcpy(&len, h.data() + pos, 4);
      pos += 4;
      if (len > h.size() - pos) return false;
      const std::string field = h.substr(pos, len);
      pos += len;
      const size_t eq = field.find('=');
      if (eq == std::string::npos) return false;
      (*out)[field.substr(0, eq)] = field.substr(eq + 1);
    }
    return true;
  }
  static uint32_t U32(const std::map<std::string, std::string>& m, const char* k) {
    auto it = m.find(k);
    uint32_t v = 0;
    if (it != m.end() && it->second.size() >= 4) std::memcpy(&v, it->second.data(), 4);
    return v;
  }
  // Marks the starts of the records inside a chunk's uncompressed bytes.
  void MarkRecords(uint64_t at, const std::vector<char>& data) {
    starts_.assign(data.size(), 0);
    uint64_t pos = 0;
    while (pos < data.size()) {
      uint32_t hl, dl;
      if (pos + 4 > data.size()) Fail(at, "record inside a chunk runs past its end");
      std::memcpy(&hl, data.data() + pos, 4);
      if (pos + 8 + uint64_t{hl} > data.size()) Fail(at, "record inside a chunk runs past its end");
      std::memcpy(&dl, data.data() + pos + 4 + hl, 4);
      if (pos + 8 + uint64_t{hl} + dl > data.size())
        Fail(at, "record inside a chunk runs past its end");
      starts_[pos] = 1;
      pos += 8 + uint64_t{hl} + dl;
    }
  }
  void Walk() {
    char magic[13];
    Read(0, magic, 13);
    if (std::memcmp(magic, "#ROSBAG V2.0\n", 13) != 0) Fail(0, "not a rosbag 2.0 file");
    uint64_t pos = 13;
    std::set<uint64_t> chunks;
    bool in_chunk = false;
    while (pos < size_) {
      uint32_t hl, dl;
      Read(pos, &hl, 4);
      if (hl > (1u << 20))
        Fail(pos, "record header length " + std::to_string(hl) + " is not plausible");
      std::string h(hl, '\0');
      Read(pos + 4, h.data(), hl);
      Read(pos + 4 + hl, &dl, 4);
      const uint64_t data_at = pos + 8 + hl;
      if (data_at + dl > size_) Fail(pos, "record data runs past the end of the file");
      std::map<std::string, std::string> fields;
      if (!Fields(h, &fields) || !fields.count("op") || fields["op"].size() != 1)
        Fail(pos, "bad record header");
      const int op = fields["op"][0];
      if (op == 0x05) {  // chunk
        const std::string compression = fields["compression"];
        const uint32_t size = U32(fields, "size");
        if (size > (1u << 30) || dl > (1u << 30))
          Fail(pos, "chunk of " + std::to_string(size) + " bytes is not plausible");
        std::vector<char> raw(dl), data(size);
        Read(data_at, raw.data(), dl);
        if (compression == "none") {
          if (dl != size)
            Fail(pos, "uncompressed chunk of " + std::to_string(dl) + " bytes says " +
                          std::to_string(size));
          data.swap(raw);
        } else if (compression == "lz4") {
          unsigned int out = size;
          if (roslz4_buffToBuffDecompress(raw.data(), dl, data.data(), &out) != ROSLZ4_OK ||
              out != size)
            Fail(pos, "lz4 chunk does not decompress to its " + std::to_string(size) + " bytes");
        } else if (compression == "bz2") {
          unsigned int out = size;
          if (BZ2_bzBuffToBuffDecompress(data.data(), &out, raw.data(), dl, 0, 0) != BZ_OK ||
              out != size)
            Fail(pos, "bz2 chunk does not decompress to its " + std::to_string(size) + " bytes");
        } else {
          // Not damage: a compression this reader does not know (rosbag writes none, lz4, bz2).
          throw BagError(path_ + ": chunk at byte " + std::to_string(pos) +
                         " uses the compression '" + compression +
                         "', which is not supported (rosbag writes none, lz4 and bz2)");
        }
        MarkRecords(pos, data);
        chunks.insert(pos);
        in_chunk = true;
      } else if (op == 0x04) {  // index data of the chunk before it
        const uint32_t count = U32(fields, "count");
        if (!in_chunk || uint64_t{count} * 12 != dl) Fail(pos, "bad index record");
        std::vector<char> entries(dl);
        Read(data_at, entries.data(), dl);
        for (uint32_t k = 0; k < count; ++k) {
          uint32_t offset;
          std::memcpy(&offset, entries.data() + 12 * k + 8, 4);
          if (offset >= starts_.size() || !starts_[offset])
            Fail(pos, "index entry " + std::to_string(k) + " points at no record of its chunk");
        }
      } else if (op == 0x06) {  // chunk info
        uint64_t chunk_pos = 0;
        auto it = fields.find("chunk_pos");
        if (it != fields.end() && it->second.size() == 8)
          std::memcpy(&chunk_pos, it->second.data(), 8);
        if (!chunks.count(chunk_pos)) Fail(pos, "chunk info points at no chunk");
        in_chunk = false;
      } else if (op != 0x03 && op != 0x07 && op != 0x02) {
        Fail(pos, "unknown record op " + std::to_string(op));
      }
      pos = data_at + dl;
    }
  }

  std::string path_;
  std::FILE* f_ = nullptr;
  uint64_t size_ = 0;
  std::vector<uint8_t> starts_;  // record starts of the current chunk
};

}  // namespace

void CheckBagStructure(const std::string& path) { BagStructureCheck(path).Run(); }

// One field on the wire. kFixed: `size` bytes; kString: a uint32 length, then
// that many bytes; kArray: a uint32 count (unless `count` >= 0 fixes it), then
// the elements, each `size` bytes, or laid out by `element` when they vary.
struct MessageLayout::Field {
  enum Kind { kFixed, kString, kArray } kind = kFixed;
  std::string type, name;  // as written in the definition; name is dotted when nested
  uint64_t size = 0;
  int64_t count = -1;
  std::shared_ptr<const std::vector<Field>> element;
};

namespace {

using Field = MessageLayout::Field;

uint64_t PrimitiveSize(const std::string& t) {
  static const std::map<std::string, uint64_t> sizes = {
      {"bool", 1},  {"int8", 1},   {"uint8", 1},   {"byte", 1},   {"char", 1},
      {"int16", 2}, {"uint16", 2}, {"int32", 4},   {"uint32", 4}, {"float32", 4},
      {"int64", 8}, {"uint64", 8}, {"float64", 8}, {"time", 8},   {"duration", 8}};
  auto it = sizes.find(t);
  return it == sizes.end() ? 0 : it->second;
}

std::string Trim(const std::string& s) {
  const size_t b = s.find_first_not_of(" \t\r");
  if (b == std::string::npos) return "";
  return s.substr(b, s.find_last_not_of(" \t\r") - b + 1);
}

// The definition text split into its messages: type -> field lines.
class Definitions {
 public:
  Definitions(const std::string& datatype, const std::string& text) : root_(datatype) {
    std::istringstream in(text);
    std::string line, current = datatype;
    while (std::getline(in, line)) {
      const std::string t = Trim(line);
      if (t.size() >= 3 && t.find_first_not_of('=') == std::string::npos) {
        current.clear();  // a separator: the next section names its type
        continue;
      }
      if (current.empty()) {
        if (t.rfind("MSG:", 0) == 0) current = Trim(t.substr(4));
        continue;
      }
      lines_[current].push_back(t);
    }
  }

  std::vector<Field> Layout(const std::string& type, const std::string& prefix, int depth) const {
    auto it = lines_.find(type);
    if (it == lines_.end()) Fail("its definition holds no section for message type '" + type + "'");
    if (depth > 32) Fail("message type '" + type + "' nests too deeply");
    const std::string package = type.substr(0, type.find('/'));
    std::vector<Field> out;
    for (const std::string& line : it->second) {
      if (line.empty() || line[0] == '#') continue;
      const size_t sp = line.find_first_of(" \t");
      if (sp == std::string::npos) Fail("cannot read the line '" + line + "'");
      const std::string type_token = line.substr(0, sp);
      const std::string rest = Trim(line.substr(sp));
      const size_t name_end = rest.find_first_of(" \t=#");
      const std::string name = rest.substr(0, name_end);
      if (name_end != std::string::npos && Trim(rest.substr(name_end)).rfind('=', 0) == 0)
        continue;  // a constant: not on the wire
      out.push_back(Make(type_token, prefix + name, package, depth));
      if (out.back().kind == Field::kFixed && out.back().element) {
        // A nested message: its fields in place of it.
        auto nested = *out.back().element;
        out.pop_back();
        out.insert(out.end(), nested.begin(), nested.end());
      }
    }
    return out;
  }

  [[noreturn]] void Fail(const std::string& what) const {
    throw std::invalid_argument(root_ + ": cannot derive the wire layout from the message " +
                                "definition: " + what);
  }

 private:
  // A field of `type_token` (e.g. "float32[]", "uint8[16]", "Header", "geometry_msgs/Point").
  // A nested message comes back as kFixed with its fields in `element`, to be flattened.
  Field Make(const std::string& type_token, const std::string& name, const std::string& package,
             int depth) const {
    Field f;
    f.type = type_token;
    f.name = name;
    std::string base = type_token;
    const size_t bracket = type_token.find('[');
    if (bracket != std::string::npos) {
      base = type_token.substr(0, bracket);
      const size_t close = type_token.find(']', bracket);
      if (close != type_token.size() - 1)
        Fail("field '" + name + "' has type '" + type_token + "'");
      const std::string n = type_token.substr(bracket + 1, close - bracket - 1);
      if (!n.empty()) {
        if (n.size() > 9 || n.find_first_not_of("0123456789") != std::string::npos)
          Fail("field '" + name + "' has type '" + type_token + "'");
        f.count = std::stoll(n);
      }
      f.kind = Field::kArray;
    }
    if (const uint64_t size = PrimitiveSize(base)) {
      f.size = size;
      return f;
    }
    std::shared_ptr<const std::vector<Field>> element;
    if (base == "string") {
      Field s;
      s.kind = Field::kString;
      s.type = base;
      s.name = f.kind == Field::kArray ? "" : name;  // an element is named by its index
      if (f.kind != Field::kArray) return s;
      element = std::make_shared<const std::vector<Field>>(std::vector<Field>{s});
    } else {
      std::string full = base;
      if (base == "Header")
        full = "std_msgs/Header";
      else if (base.find('/') == std::string::npos)
        full = package + "/" + base;
      if (!lines_.count(full))
        Fail("field '" + name + "' has type '" + type_token + "', which is neither a ROS " +
             "primitive nor a message its definition includes");
      element = std::make_shared<const std::vector<Field>>(
          Layout(full, f.kind == Field::kArray ? "." : name + ".", depth + 1));
    }
    if (f.kind != Field::kArray) {
      f.element = element;  // flattened by the caller
      return f;
    }
    // An array of messages: fixed-size elements are counted by their size.
    bool fixed = true;
    uint64_t size = 0;
    for (const Field& e : *element) {
      fixed = fixed && e.kind == Field::kFixed;
      size += e.size;
    }
    if (fixed && !element->empty())
      f.size = size;
    else if (!element->empty())
      f.element = element;
    return f;  // an array of empty messages takes only its count
  }

  std::string root_;
  std::map<std::string, std::vector<std::string>> lines_;
};

bool Walk(const std::vector<Field>& fields, const uint8_t* data, uint64_t n, uint64_t* pos,
          const std::string& prefix, std::string* why) {
  uint64_t start = *pos;
  auto fail = [&](const Field& f, const std::string& what) {
    if (why) {
      *why = "field '" + prefix + f.name + "' (" + f.type + ") at byte " + std::to_string(start) +
             " " + what;
    }
    return false;
  };
  for (const Field& f : fields) {
    start = *pos;
    if (f.kind == Field::kFixed) {
      if (n - *pos < f.size)
        return fail(f, "runs past the message's " + std::to_string(n) + " bytes");
      *pos += f.size;
      continue;
    }
    uint64_t count = 0;
    if (f.kind == Field::kArray && f.count >= 0) {
      count = static_cast<uint64_t>(f.count);
    } else {
      if (n - *pos < 4) return fail(f, "runs past the message's " + std::to_string(n) + " bytes");
      uint32_t len;
      std::memcpy(&len, data + *pos, 4);
      *pos += 4;
      count = len;
    }
    const uint64_t left = n - *pos;
    const char* unit = f.kind == Field::kString ? " bytes" : " items";
    if (f.kind == Field::kString || !f.element) {
      const uint64_t item = f.kind == Field::kString ? 1 : f.size;
      if (item != 0 && count > left / item)
        return fail(f, "declares " + std::to_string(count) + unit + " but " + std::to_string(left) +
                           " bytes are left");
      *pos += count * item;
      continue;
    }
    // Elements of varying size: each takes at least its first length field.
    if (count > left / 4)
      return fail(f, "declares " + std::to_string(count) + unit + " but " + std::to_string(left) +
                         " bytes are left");
    for (uint64_t k = 0; k < count; ++k)
      if (!Walk(*f.element, data, n, pos, prefix + f.name + "[" + std::to_string(k) + "]", why))
        return false;
  }
  return true;
}

void DescribeInto(const std::vector<Field>& fields, std::string* out) {
  for (const Field& f : fields) {
    if (!out->empty()) *out += ", ";
    *out += f.type + " " + f.name;
  }
}

}  // namespace

MessageLayout::MessageLayout(const std::string& datatype, const std::string& definition)
    : datatype_(datatype) {
  Definitions defs(datatype, definition);
  fields_ = defs.Layout(datatype, "", 0);
  if (fields_.empty()) defs.Fail("it declares no field");
}

MessageLayout::~MessageLayout() = default;

bool MessageLayout::Fits(const uint8_t* data, size_t n, std::string* why) const {
  uint64_t pos = 0;
  if (!Walk(fields_, data, n, &pos, "", why)) return false;
  if (pos != n) {
    if (why) {
      *why = std::to_string(n - pos) + " bytes left over after the last field (" +
             std::to_string(pos) + " of " + std::to_string(n) + " bytes laid out)";
    }
    return false;
  }
  return true;
}

std::string MessageLayout::Describe() const {
  std::string out;
  DescribeInto(fields_, &out);
  return out;
}

}  // namespace msspr::ros_bridge
