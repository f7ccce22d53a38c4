#include "msspr_core/npz.h"

#include <zip.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <sstream>

namespace msspr {
namespace core {
namespace {

struct ZipCloser {
  void operator()(zip_t* z) const {
    if (z) zip_discard(z);
  }
};
struct ZipFileCloser {
  void operator()(zip_file_t* f) const {
    if (f) zip_fclose(f);
  }
};
using ZipPtr = std::unique_ptr<zip_t, ZipCloser>;
using ZipFilePtr = std::unique_ptr<zip_file_t, ZipFileCloser>;

[[noreturn]] void Fail(const std::string& path, const std::string& key, const std::string& what) {
  throw NpzError(path + (key.empty() ? "" : ": key '" + key + "'") + ": " + what);
}

std::string ShapeString(const std::vector<int64_t>& s) {
  std::string r = "(";
  for (size_t i = 0; i < s.size(); ++i) r += (i ? ", " : "") + std::to_string(s[i]);
  return r + ")";
}

// Runs fn; any exception other than NpzError becomes one naming the file.
template <class Fn>
auto NamingFile(const std::string& path, Fn&& fn) -> decltype(fn()) {
  try {
    return fn();
  } catch (const NpzError&) {
    throw;
  } catch (const std::exception& e) {
    Fail(path, "", e.what());
  }
}

// Rejects NaN and Inf: counts them and names the first row.
void CheckFinite(const std::vector<float>& v, int64_t row_size, const std::string& path,
                 const std::string& key) {
  int64_t bad = 0, first = -1;
  for (size_t i = 0; i < v.size(); ++i)
    if (!std::isfinite(v[i])) {
      if (first < 0) first = static_cast<int64_t>(i);
      ++bad;
    }
  if (bad > 0)
    Fail(path, key,
         std::to_string(bad) + " non-finite values (NaN or Inf), the first in row " +
             std::to_string(first / std::max<int64_t>(row_size, 1)));
}

ZipPtr OpenZip(const std::string& path) {
  int err = 0;
  zip_t* z = zip_open(path.c_str(), ZIP_RDONLY, &err);
  if (!z) {
    zip_error_t e;
    zip_error_init_with_code(&e, err);
    std::string msg = zip_error_strerror(&e);
    zip_error_fini(&e);
    Fail(path, "", "cannot open as .npz (zip): " + msg);
  }
  return ZipPtr(z);
}

void ReadExact(zip_file_t* f, void* dst, uint64_t n, const std::string& path,
               const std::string& key) {
  auto* p = static_cast<char*>(dst);
  while (n > 0) {
    const uint64_t chunk = std::min<uint64_t>(n, uint64_t{1} << 30);
    const zip_int64_t got = zip_fread(f, p, chunk);
    if (got <= 0) Fail(path, key, "array data truncated or corrupt");
    p += got;
    n -= static_cast<uint64_t>(got);
  }
}

// Parses the .npy header (format versions 1-3) and leaves `f` at the data.
NpyInfo ReadHeader(zip_file_t* f, const std::string& path, const std::string& key) {
  unsigned char pre[10];
  ReadExact(f, pre, 8, path, key);
  if (std::memcmp(pre, "\x93NUMPY", 6) != 0) Fail(path, key, "not a .npy array (bad magic)");
  const int major = pre[6];
  uint32_t header_len = 0;
  if (major == 1) {
    unsigned char l[2];
    ReadExact(f, l, 2, path, key);
    header_len = l[0] | (l[1] << 8);
  } else if (major == 2 || major == 3) {
    unsigned char l[4];
    ReadExact(f, l, 4, path, key);
    header_len = l[0] | (l[1] << 8) | (l[2] << 16) | (uint32_t{l[3]} << 24);
  } else {
    Fail(path, key, "unsupported .npy version " + std::to_string(major));
  }
  if (header_len > (1u << 20)) Fail(path, key, "bad .npy header length");
  const uint64_t data_offset = (major == 1 ? 10 : 12) + uint64_t{header_len};
  std::string h(header_len, '\0');
  ReadExact(f, h.data(), header_len, path, key);
  NpyInfo info;
  auto find_value = [&](const char* name) -> size_t {
    const size_t k = h.find(std::string("'") + name + "'");
    if (k == std::string::npos) Fail(path, key, std::string("bad .npy header: no '") + name + "'");
    const size_t colon = h.find(':', k);
    if (colon == std::string::npos) Fail(path, key, "bad .npy header");
    return h.find_first_not_of(" ", colon + 1);
  };
  size_t v = find_value("descr");
  if (v == std::string::npos || (h[v] != '\'' && h[v] != '"')) Fail(path, key, "bad .npy descr");
  const size_t v_end = h.find(h[v], v + 1);
  if (v_end == std::string::npos) Fail(path, key, "bad .npy descr");
  info.descr = h.substr(v + 1, v_end - v - 1);
  v = find_value("fortran_order");
  info.fortran_order = h.compare(v, 4, "True") == 0;
  v = find_value("shape");
  if (v == std::string::npos || h[v] != '(') Fail(path, key, "bad .npy shape");
  const size_t s_end = h.find(')', v);
  if (s_end == std::string::npos) Fail(path, key, "bad .npy shape");
  std::stringstream shape(h.substr(v + 1, s_end - v - 1));
  std::string item;
  while (std::getline(shape, item, ',')) {
    if (item.find_first_not_of(" ") == std::string::npos) continue;
    try {
      info.shape.push_back(std::stoll(item));
    } catch (const std::exception&) {
      Fail(path, key, "bad .npy shape '" + h.substr(v, s_end - v + 1) + "'");
    }
  }
  info.data_offset = static_cast<int64_t>(data_offset);
  for (int64_t d : info.shape)
    if (d < 0)
      Fail(path, key, "bad .npy shape '" + h.substr(v, s_end - v + 1) + "': negative dimension");
  if (info.numel() < 0)
    Fail(path, key, "bad .npy shape '" + h.substr(v, s_end - v + 1) + "': too many elements");
  if (info.fortran_order && info.shape.size() > 1)
    Fail(path, key, "fortran_order arrays are not supported");
  if (info.descr.size() < 3 || info.descr[0] == '>') {
    Fail(path, key, "unsupported dtype '" + info.descr + "' (little-endian numeric expected)");
  }
  return info;
}

ZipFilePtr OpenArray(zip_t* z, const std::string& path, const std::string& key) {
  zip_file_t* f = zip_fopen(z, (key + ".npy").c_str(), 0);
  if (!f) Fail(path, key, "missing array");
  return ZipFilePtr(f);
}

// Bytes per element of a numeric dtype ("<f4" -> 4), 0 when unknown.
int64_t ItemSize(const std::string& descr) {
  const std::string t = descr.size() >= 3 ? descr.substr(1) : "";
  if (t == "f8" || t == "i8" || t == "u8") return 8;
  if (t == "f4" || t == "i4" || t == "u4") return 4;
  if (t == "i2" || t == "u2" || t == "f2") return 2;
  if (t == "i1" || t == "u1" || t == "b1") return 1;
  return 0;
}

// The header must describe exactly the bytes the zip entry holds: a lying
// shape never drives an allocation.
void CheckEntrySize(zip_t* z, const NpyInfo& info, const std::string& path,
                    const std::string& key) {
  zip_stat_t st;
  zip_stat_init(&st);
  if (zip_stat(z, (key + ".npy").c_str(), 0, &st) != 0 || !(st.valid & ZIP_STAT_SIZE))
    Fail(path, key, "cannot read the entry's size");
  const int64_t item = ItemSize(info.descr);
  if (item == 0) return;  // unsupported dtypes fail when read
  const int64_t n = info.numel();
  if (n > (std::numeric_limits<int64_t>::max() - info.data_offset) / item)
    Fail(path, key, "shape " + ShapeString(info.shape) + " is too large");
  const uint64_t expected = static_cast<uint64_t>(info.data_offset + n * item);
  if (st.size != expected)
    Fail(path, key,
         "header says shape " + ShapeString(info.shape) + " of '" + info.descr + "' (" +
             std::to_string(expected - info.data_offset) + " data bytes), but the entry holds " +
             (st.size >= static_cast<uint64_t>(info.data_offset)
                  ? std::to_string(st.size - info.data_offset)
                  : std::string("less than a header")) +
             " (truncated or lying header)");
}

template <class Dst, class Src>
void Convert(const std::vector<char>& raw, int64_t n, Dst* out) {
  const Src* src = reinterpret_cast<const Src*>(raw.data());
  for (int64_t i = 0; i < n; ++i) out[i] = static_cast<Dst>(src[i]);
}

// Reads the array data into out (numel elements of Dst), converting.
template <class Dst>
void ReadConverted(zip_file_t* f, const NpyInfo& info, Dst* out, const std::string& path,
                   const std::string& key, bool allow_any) {
  const int64_t n = info.numel();
  const std::string t = info.descr.substr(1);
  const bool same = (std::is_same<Dst, float>::value && t == "f4") ||
                    (std::is_same<Dst, uint8_t>::value && (t == "u1" || t == "b1"));
  if (same) {
    ReadExact(f, out, sizeof(Dst) * n, path, key);
    return;
  }
  if (!allow_any) Fail(path, key, "dtype '" + info.descr + "' cannot be read as this type");
  int size = 0;
  if (t == "f8" || t == "i8" || t == "u8")
    size = 8;
  else if (t == "f4" || t == "i4" || t == "u4")
    size = 4;
  else if (t == "i2" || t == "u2")
    size = 2;
  else if (t == "i1" || t == "u1" || t == "b1")
    size = 1;
  else
    Fail(path, key, "unsupported dtype '" + info.descr + "'");
  std::vector<char> raw(static_cast<size_t>(n) * size);
  ReadExact(f, raw.data(), raw.size(), path, key);
  if (t == "f8")
    Convert<Dst, double>(raw, n, out);
  else if (t == "f4")
    Convert<Dst, float>(raw, n, out);
  else if (t == "i8")
    Convert<Dst, int64_t>(raw, n, out);
  else if (t == "u8")
    Convert<Dst, uint64_t>(raw, n, out);
  else if (t == "i4")
    Convert<Dst, int32_t>(raw, n, out);
  else if (t == "u4")
    Convert<Dst, uint32_t>(raw, n, out);
  else if (t == "i2")
    Convert<Dst, int16_t>(raw, n, out);
  else if (t == "u2")
    Convert<Dst, uint16_t>(raw, n, out);
  else if (t == "i1")
    Convert<Dst, int8_t>(raw, n, out);
  else
    Convert<Dst, uint8_t>(raw, n, out);
}

template <class Dst>
std::vector<Dst> ReadArray(zip_t* z, const std::string& path, const std::string& key,
                           NpyInfo* info_out, bool allow_any) {
  ZipFilePtr f = OpenArray(z, path, key);
  NpyInfo info = ReadHeader(f.get(), path, key);
  CheckEntrySize(z, info, path, key);
  std::vector<Dst> out(static_cast<size_t>(info.numel()));
  ReadConverted<Dst>(f.get(), info, out.data(), path, key, allow_any);
  if (info_out) *info_out = info;
  return out;
}

NpyInfo PeekArray(zip_t* z, const std::string& path, const std::string& key) {
  ZipFilePtr f = OpenArray(z, path, key);
  NpyInfo info = ReadHeader(f.get(), path, key);
  CheckEntrySize(z, info, path, key);
  return info;
}

bool HasArray(zip_t* z, const std::string& key) {
  return zip_name_locate(z, (key + ".npy").c_str(), 0) >= 0;
}

std::string NpyHeader(const std::string& descr, const std::vector<int64_t>& shape) {
  std::string shape_str = "(";
  for (size_t i = 0; i < shape.size(); ++i) shape_str += std::to_string(shape[i]) + ",";
  if (shape.size() > 1) shape_str.pop_back();
  shape_str += ")";
  std::string dict =
      "{'descr': '" + descr + "', 'fortran_order': False, 'shape': " + shape_str + ", }";
  // Version 1.0: magic(6) + version(2) + len(2) + dict padded with spaces
  // and a newline to a multiple of 64.
  size_t total = 10 + dict.size() + 1;
  dict.append((64 - total % 64) % 64, ' ');
  dict.push_back('\n');
  std::string h("\x93NUMPY\x01\x00", 8);
  const uint16_t len = static_cast<uint16_t>(dict.size());
  h.push_back(static_cast<char>(len & 0xff));
  h.push_back(static_cast<char>(len >> 8));
  return h + dict;
}

}  // namespace

int64_t NpyInfo::numel() const {
  int64_t n = 1;
  for (int64_t s : shape)
    if (s < 0 || __builtin_mul_overflow(n, s, &n)) return -1;
  return n;
}

std::vector<std::string> ListNpzKeys(const std::string& path) {
  return NamingFile(path, [&] {
    ZipPtr z = OpenZip(path);
    std::vector<std::string> keys;
    const zip_int64_t n = zip_get_num_entries(z.get(), 0);
    for (zip_int64_t i = 0; i < n; ++i) {
      std::string name = zip_get_name(z.get(), i, 0);
      if (name.size() > 4 && name.compare(name.size() - 4, 4, ".npy") == 0) {
        keys.push_back(name.substr(0, name.size() - 4));
      }
    }
    return keys;
  });
}

std::vector<float> ReadNpzFloat(const std::string& path, const std::string& key, NpyInfo* info) {
  return NamingFile(path, [&] {
    ZipPtr z = OpenZip(path);
    return ReadArray<float>(z.get(), path, key, info, true);
  });
}

std::vector<uint8_t> ReadNpzUint8(const std::string& path, const std::string& key, NpyInfo* info) {
  return NamingFile(path, [&] {
    ZipPtr z = OpenZip(path);
    return ReadArray<uint8_t>(z.get(), path, key, info, false);
  });
}

Dataset LoadNpzDataset(const std::string& path) {
  return NamingFile(path, [&] {
    ZipPtr z = OpenZip(path);
    zip_t* zp = z.get();
    const NpyInfo obs_info = PeekArray(zp, path, "observations");
    if (obs_info.shape.empty()) Fail(path, "observations", "scalar array, expected [N, ...]");
    const int64_t n = obs_info.shape[0];
    if (n <= 0) Fail(path, "observations", "empty array");
    const bool obs_is_image = obs_info.descr == "|u1" || obs_info.descr == "<u1";

    std::vector<float> states;
    std::vector<uint8_t> images;
    int obs_dim = 0;
    ImageShape image_shape;
    auto read_images = [&](const std::string& key, const NpyInfo& info) {
      if (info.shape.size() != 4 || info.shape[0] != n) {
        Fail(path, key,
             "shape " + ShapeString(info.shape) + ", expected [" + std::to_string(n) +
                 ", H, W, C] uint8");
      }
      for (int d = 1; d < 4; ++d)
        if (info.shape[d] <= 0 || info.shape[d] > 65535)
          Fail(path, key, "shape " + ShapeString(info.shape) + ": image dimension out of range");
      image_shape = {static_cast<int>(info.shape[1]), static_cast<int>(info.shape[2]),
                     static_cast<int>(info.shape[3])};
      images = ReadArray<uint8_t>(zp, path, key, nullptr, false);
    };
    if (obs_is_image) {
      read_images("observations", obs_info);
    } else {
      if (obs_info.shape.size() != 2) {
        Fail(path, "observations",
             "shape " + ShapeString(obs_info.shape) +
                 ", expected [N, obs_dim] (float) or [N, H, W, C] (uint8)");
      }
      if (obs_info.shape[1] <= 0 || obs_info.shape[1] > (1 << 20))
        Fail(path, "observations",
             "shape " + ShapeString(obs_info.shape) + ": obs_dim out of range");
      obs_dim = static_cast<int>(obs_info.shape[1]);
      states = ReadArray<float>(zp, path, "observations", nullptr, true);
      CheckFinite(states, obs_dim, path, "observations");
      if (HasArray(zp, "images")) read_images("images", PeekArray(zp, path, "images"));
    }

    NpyInfo act_info;
    std::vector<float> actions = ReadArray<float>(zp, path, "actions", &act_info, true);
    if (act_info.shape.size() != 2 || act_info.shape[0] != n || act_info.shape[1] <= 0 ||
        act_info.shape[1] > (1 << 20)) {
      Fail(path, "actions",
           "shape " + ShapeString(act_info.shape) + ", expected [" + std::to_string(n) +
               ", action_dim]");
    }
    CheckFinite(actions, act_info.shape[1], path, "actions");
    NpyInfo term_info;
    std::vector<float> term = ReadArray<float>(zp, path, "terminals", &term_info, true);
    if (term_info.shape.size() != 1 || term_info.shape[0] != n) {
      Fail(path, "terminals",
           "shape " + ShapeString(term_info.shape) + ", expected [" + std::to_string(n) + "]");
    }
    std::vector<uint8_t> terminals(n);
    for (int64_t i = 0; i < n; ++i) terminals[i] = term[i] != 0.0f;
    try {
      return Dataset::FromArrays(std::move(states), obs_dim, std::move(images), image_shape,
                                 std::move(actions), static_cast<int>(act_info.shape[1]),
                                 terminals);
    } catch (const DatasetError& e) {
      Fail(path, "", e.what());
    }
  });
}

void SaveNpzArrays(const std::string& path, const std::vector<NpyArray>& arrays, bool compress) {
  const std::string tmp = path + ".tmp";
  std::remove(tmp.c_str());
  int err = 0;
  zip_t* z = zip_open(tmp.c_str(), ZIP_CREATE | ZIP_TRUNCATE, &err);
  if (!z) Fail(path, "", "cannot create file");
  ZipPtr guard(z);
  // Headers must stay alive until zip_close.
  std::vector<std::unique_ptr<std::string>> headers;
  for (const NpyArray& a : arrays) {
    int64_t numel = 1;
    for (int64_t d : a.shape) numel *= d;
    if (numel * ItemSize(a.descr) != static_cast<int64_t>(a.bytes))
      Fail(path, a.key,
           "holds " + std::to_string(a.bytes) + " bytes, not those of its shape " +
               ShapeString(a.shape) + " of " + a.descr);
    headers.push_back(std::make_unique<std::string>(NpyHeader(a.descr, a.shape)));
    zip_buffer_fragment_t frags[2];
    frags[0].data = reinterpret_cast<zip_uint8_t*>(headers.back()->data());
    frags[0].length = headers.back()->size();
    frags[1].data = static_cast<zip_uint8_t*>(const_cast<void*>(a.data));
    frags[1].length = a.bytes;
    zip_source_t* src = zip_source_buffer_fragment(z, frags, a.bytes > 0 ? 2 : 1, 0);
    if (!src) Fail(path, a.key, "cannot create zip source");
    const zip_int64_t idx = zip_file_add(z, (a.key + ".npy").c_str(), src, ZIP_FL_OVERWRITE);
    if (idx < 0) {
      zip_source_free(src);
      Fail(path, a.key, std::string("cannot add: ") + zip_strerror(z));
    }
    zip_set_file_compression(z, idx, compress ? ZIP_CM_DEFLATE : ZIP_CM_STORE, 0);
  }
  if (zip_close(z) != 0) {
    const std::string msg = zip_strerror(z);
    Fail(path, "", "cannot write: " + msg);
  }
  guard.release();
  if (std::rename(tmp.c_str(), path.c_str()) != 0) Fail(path, "", "cannot rename temporary file");
}

void SaveNpzDataset(const Dataset& data, const std::string& path, bool compress) {
  const int64_t n = data.size();
  std::vector<float> terminals(n);
  {
    const std::vector<uint8_t> t = data.terminals();
    for (int64_t i = 0; i < n; ++i) terminals[i] = t[i];
  }
  std::vector<NpyArray> arrays;
  const ImageShape& is = data.image_shape();
  if (data.has_states()) {
    arrays.push_back({"observations",
                      "<f4",
                      {n, data.obs_dim()},
                      data.states().data(),
                      sizeof(float) * data.states().size()});
    if (data.has_images())
      arrays.push_back({"images",
                        "|u1",
                        {n, is.height, is.width, is.channels},
                        data.images().data(),
                        data.images().size()});
  } else {
    arrays.push_back({"observations",
                      "|u1",
                      {n, is.height, is.width, is.channels},
                      data.images().data(),
                      data.images().size()});
  }
  arrays.push_back({"actions",
                    "<f4",
                    {n, data.action_dim()},
                    data.actions().data(),
                    sizeof(float) * data.actions().size()});
  arrays.push_back({"terminals", "<f4", {n}, terminals.data(), sizeof(float) * terminals.size()});
  SaveNpzArrays(path, arrays, compress);
}

}  // namespace core
}  // namespace msspr
