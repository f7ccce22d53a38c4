#include "dataset_bag.h"

#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <roslz4/lz4s.h>
#include <sensor_msgs/Image.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <set>
#include <sstream>

#include "msg_conversion.h"
#include "msspr/Action.h"
#include "msspr/EpisodeInfo.h"
#include "msspr/Observation.h"

namespace msspr::ros_bridge {

DatasetBagWriter::DatasetBagWriter(const std::string& path, double control_dt, bool lz4)
    : path_(path),
      tmp_path_(path + ".tmp." + std::to_string(::getpid())),
      control_dt_(control_dt),
      bag_(std::make_unique<rosbag::Bag>()) {
  try {
    bag_->open(tmp_path_, rosbag::bagmode::Write);
  } catch (const rosbag::BagException& e) {
    throw BagError(path + ": cannot open " + tmp_path_ + " for writing: " + e.what());
  }
  if (lz4) bag_->setCompression(rosbag::compression::LZ4);
}

DatasetBagWriter::~DatasetBagWriter() {
  // Not closed: the writing failed or was abandoned; an existing bag at path_ stays.
  try {
    if (bag_ && bag_->isOpen()) bag_->close();
  } catch (...) {
  }
  if (!closed_) std::remove(tmp_path_.c_str());
}

void DatasetBagWriter::Close() {
  if (closed_) return;
  try {
    if (bag_ && bag_->isOpen()) bag_->close();
  } catch (const rosbag::BagException& e) {
    throw BagError(tmp_path_ + ": cannot finish writing: " + e.what());
  }
  if (std::rename(tmp_path_.c_str(), path_.c_str()) != 0)
    throw BagError(path_ + ": cannot rename " + tmp_path_ + " to it: " + std::strerror(errno));
  closed_ = true;
}

void DatasetBagWriter::WriteEpisode(const EpisodeMeta& meta, int length, int obs_dim, int act_dim,
                                    const float* observations, const float* actions,
                                    const uint8_t* images, int image_size, double success_radius) {
  if (closed_ || !bag_->isOpen()) throw BagError(path_ + ": writer already closed");
  ++tick_;  // the reset
  const ros::Time t0 = TickToTime(tick_, control_dt_);
  msspr::EpisodeInfo info;
  info.header.stamp = t0;
  info.episode_id = static_cast<uint32_t>(meta.episode_id);
  info.env = meta.env;
  info.split = meta.split;
  info.task_id = meta.task_id;
  info.seed = meta.seed;
  info.start = meta.start;
  info.goal = meta.goal;
  bag_->write(kEpisodeTopic, t0, info);
  ++messages_;

  msspr::Observation obs;
  obs.episode_id = info.episode_id;
  obs.goal = meta.goal;
  obs.header.frame_id = "world";
  msspr::Action act;
  act.episode_id = info.episode_id;
  const size_t image_bytes = static_cast<size_t>(image_size) * image_size * 3;
  for (int t = 0; t < length; ++t) {
    if (t > 0) ++tick_;
    const ros::Time stamp = TickToTime(tick_, control_dt_);
    obs.header.stamp = stamp;
    obs.step = static_cast<uint32_t>(t);
    obs.state.assign(observations + static_cast<size_t>(t) * obs_dim,
                     observations + static_cast<size_t>(t + 1) * obs_dim);
    double d2 = 0.0;
    for (int k = 0; k < obs_dim && k < static_cast<int>(meta.goal.size()); ++k) {
      const double d = static_cast<double>(obs.state[k]) - meta.goal[k];
      d2 += d * d;
    }
    obs.success = !meta.goal.empty() && std::sqrt(d2) <= success_radius;
    obs.last = (t == length - 1);
    bag_->write(kObservationTopic, stamp, obs);
    if (images != nullptr) {
      bag_->write(kImageTopic, stamp,
                  ToImageMsg(images + static_cast<size_t>(t) * image_bytes, image_size, stamp,
                             kCameraFrame));
      ++messages_;
    }
    act.header.stamp = stamp;
    act.step = obs.step;
    act.action.assign(actions + static_cast<size_t>(t) * act_dim,
                      actions + static_cast<size_t>(t + 1) * act_dim);
    bag_->write(kActionTopic, stamp, act);
    messages_ += 2;
  }
}

std::vector<std::pair<int, int>> BagEpisode::Segments() const {
  std::vector<std::pair<int, int>> out;
  const bool need_image = image_size > 0;
  int begin = -1;
  for (int t = 0; t <= num_steps; ++t) {
    const bool ok = t < num_steps && has_obs[t] && has_action[t] && (!need_image || has_image[t]);
    if (ok && begin < 0) begin = t;
    if (!ok && begin >= 0) {
      out.emplace_back(begin, t);
      begin = -1;
    }
  }
  return out;
}

namespace {

// rosbag (1.15) trusts the lengths and offsets stored in a bag: a corrupt index
// entry or record length makes it read outside its buffers and crash. So the
// reader first walks the file's records (format 2.0) and checks every length
// against the bytes that hold it, decompresses each chunk (lz4 or none) and
// checks that every index entry points at a whole record inside it. Throws
// BagError naming the file and the byte offset.
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
        } else {
          Fail(pos, "unsupported chunk compression '" + compression + "'");
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

// Whether a serialized message of `layout` fills exactly its bytes. The ROS
// deserializer sizes an array from its length field before checking it
// against the data, so a corrupt length would allocate gigabytes first.
// Layout: H header, 1/4/8 fixed bytes, s string, f float32[], b uint8[].
bool LayoutFits(const std::vector<uint8_t>& buf, const char* layout) {
  const uint64_t n = buf.size();
  uint64_t pos = 0;
  auto length = [&](uint64_t item) {
    if (pos + 4 > n) return false;
    uint32_t len;
    std::memcpy(&len, buf.data() + pos, 4);
    pos += 4 + item * len;
    return true;
  };
  for (const char* c = layout; *c; ++c) {
    bool ok = true;
    switch (*c) {
      case 'H':
        pos += 12, ok = pos <= n && length(1);
        break;  // seq, stamp, frame_id
      case '1':
        pos += 1;
        break;
      case '4':
        pos += 4;
        break;
      case '8':
        pos += 8;
        break;
      case 's':
      case 'b':
        ok = length(1);
        break;
      case 'f':
        ok = length(4);
        break;
    }
    if (!ok || pos > n) return false;
  }
  return pos == n;
}

// MessageInstance::instantiate with the bytes checked first (nullptr for
// another type, as instantiate). Throws BagError naming the bag for a corrupt message.
template <class M>
boost::shared_ptr<M> Instantiate(const rosbag::MessageInstance& m, const char* layout,
                                 const std::string& path, uint64_t index) {
  if (m.getMD5Sum() != ros::message_traits::md5sum<M>() && m.getMD5Sum() != "*") return nullptr;
  std::vector<uint8_t> buf(m.size());
  ros::serialization::OStream out(buf.data(), static_cast<uint32_t>(buf.size()));
  m.write(out);
  if (!LayoutFits(buf, layout))
    throw BagError(path + ": message " + std::to_string(index) + " on " + m.getTopic() +
                   " is corrupt (its " + std::to_string(buf.size()) + " bytes do not hold the " +
                   ros::message_traits::datatype<M>() + " its fields declare)");
  auto msg = boost::make_shared<M>();
  ros::serialization::IStream in(buf.data(), static_cast<uint32_t>(buf.size()));
  ros::serialization::deserialize(in, *msg);
  return msg;
}

// Collects the messages of one episode until it can be finalised.
struct PartialEpisode {
  BagEpisode ep;
  std::map<uint32_t, msspr::Observation::ConstPtr> obs;
  std::map<uint32_t, msspr::Action::ConstPtr> actions;
  std::map<ros::Time, sensor_msgs::Image::ConstPtr> images;  // keyed by stamp
  uint64_t duplicates = 0;
};

// Describes missing steps compactly: "3 (steps 10-12)".
std::string DescribeMissing(const std::vector<uint8_t>& have, int n, uint64_t* count) {
  std::ostringstream s;
  std::vector<std::pair<int, int>> runs;
  for (int t = 0; t < n; ++t) {
    if (have[t]) continue;
    if (!runs.empty() && runs.back().second == t - 1)
      runs.back().second = t;
    else
      runs.emplace_back(t, t);
  }
  uint64_t c = 0;
  for (auto& r : runs) c += static_cast<uint64_t>(r.second - r.first + 1);
  *count += c;
  if (runs.empty()) return "";
  s << c << " (step" << (c > 1 ? "s " : " ");
  for (size_t i = 0; i < runs.size() && i < 4; ++i) {
    if (i) s << ", ";
    s << runs[i].first;
    if (runs[i].second != runs[i].first) s << "-" << runs[i].second;
  }
  if (runs.size() > 4) s << ", ...";
  s << ")";
  return s.str();
}

// A self-consistent rgb8 image: its side, or 0.
uint32_t RgbSide(const sensor_msgs::Image& img) {
  if (img.encoding != "rgb8" || img.width != img.height || img.width == 0 ||
      img.width > kMaxImageSide)
    return 0;
  if (uint64_t{img.step} != uint64_t{img.width} * 3 ||
      img.data.size() != uint64_t{img.step} * img.height)
    return 0;
  return img.width;
}

BagEpisode Finalize(PartialEpisode&& p, BagReadReport* report) {
  BagEpisode ep = std::move(p.ep);
  const std::string who = "episode " + std::to_string(ep.meta.episode_id) + ": ";
  // Step indices come from the data: one far beyond the episode's observed
  // length (twice the number of distinct steps it carries) is rejected, so a
  // corrupt `step` never drives an allocation.
  std::map<uint32_t, int> distinct;
  for (auto& kv : p.obs) distinct[kv.first] = 1;
  for (auto& kv : p.actions) distinct[kv.first] = 1;
  const uint64_t limit = std::max<uint64_t>(16, 2 * distinct.size());
  uint32_t max_step = 0;
  bool any = false;
  for (auto& [t, one] : distinct) {
    if (t >= limit) {
      ++report->out_of_range_steps;
      ep.problems.push_back(who + "step " + std::to_string(t) + " out of range (episode has " +
                            std::to_string(distinct.size()) + " steps)");
      continue;
    }
    max_step = std::max(max_step, t), any = true;
  }
  for (auto it = p.obs.begin(); it != p.obs.end();)
    it = it->first >= limit ? p.obs.erase(it) : std::next(it);
  for (auto it = p.actions.begin(); it != p.actions.end();)
    it = it->first >= limit ? p.actions.erase(it) : std::next(it);
  ep.num_steps = any ? static_cast<int>(max_step) + 1 : 0;
  const int n = ep.num_steps;
  ep.has_obs.assign(n, 0);
  ep.has_action.assign(n, 0);
  ep.has_image.assign(n, 0);
  if (!p.obs.empty()) ep.obs_dim = static_cast<int>(p.obs.begin()->second->state.size());
  if (!p.actions.empty()) ep.act_dim = static_cast<int>(p.actions.begin()->second->action.size());
  ep.observations.assign(static_cast<size_t>(n) * ep.obs_dim, 0.f);
  ep.actions.assign(static_cast<size_t>(n) * ep.act_dim, 0.f);
  // NaN / Inf: the step is rejected (counted, and it splits the episode as a gap would).
  std::vector<uint32_t> bad_obs, bad_act;
  for (auto& [t, m] : p.obs) {
    if (static_cast<int>(m->state.size()) != ep.obs_dim) {
      ep.problems.push_back(who + "observation at step " + std::to_string(t) + " has " +
                            std::to_string(m->state.size()) + " numbers, expected " +
                            std::to_string(ep.obs_dim));
      continue;
    }
    if (!AllFinite(m->state)) {
      bad_obs.push_back(t);
      continue;
    }
    std::copy(m->state.begin(), m->state.end(), ep.observations.begin() + t * ep.obs_dim);
    ep.has_obs[t] = 1;
  }
  for (auto& [t, m] : p.actions) {
    if (static_cast<int>(m->action.size()) != ep.act_dim) {
      ep.problems.push_back(who + "action at step " + std::to_string(t) + " has " +
                            std::to_string(m->action.size()) + " numbers, expected " +
                            std::to_string(ep.act_dim));
      continue;
    }
    if (!AllFinite(m->action)) {
      bad_act.push_back(t);
      continue;
    }
    std::copy(m->action.begin(), m->action.end(), ep.actions.begin() + t * ep.act_dim);
    ep.has_action[t] = 1;
  }
  auto describe = [&](const std::vector<uint32_t>& steps, const char* what, uint64_t* count) {
    if (steps.empty()) return;
    *count += steps.size();
    std::string list;
    for (size_t i = 0; i < steps.size() && i < 4; ++i)
      list += (i ? ", " : "") + std::to_string(steps[i]);
    ep.problems.push_back(who + std::to_string(steps.size()) + " " + what +
                          " with NaN or Inf rejected (step" + (steps.size() > 1 ? "s " : " ") +
                          list + (steps.size() > 4 ? ", ..." : "") + ")");
  };
  describe(bad_obs, "observations", &report->nonfinite_observations);
  describe(bad_act, "actions", &report->nonfinite_actions);
  // The image size is the most common one among self-consistent rgb8 images;
  // the rest are reported per step below.
  std::map<uint32_t, int> sides;
  for (auto& kv : p.images)
    if (const uint32_t side = RgbSide(*kv.second)) ++sides[side];
  if (!p.images.empty() && sides.empty())
    ep.problems.push_back(who + std::to_string(p.images.size()) +
                          " images, none a consistent rgb8 image (size, step and data disagree)");
  if (!sides.empty()) {
    const auto best = std::max_element(sides.begin(), sides.end(),
                                       [](auto& a, auto& b) { return a.second < b.second; });
    ep.image_size = static_cast<int>(best->first);
    const size_t bytes = static_cast<size_t>(ep.image_size) * ep.image_size * 3;
    if (bytes * n > kMaxEpisodeImageBytes) {
      ep.problems.push_back(who + "images of " + std::to_string(ep.image_size) + "x" +
                            std::to_string(ep.image_size) + " for " + std::to_string(n) +
                            " steps exceed the per-episode limit; images dropped");
      ep.image_size = 0;
    }
  }
  if (ep.image_size > 0) {
    const size_t bytes = static_cast<size_t>(ep.image_size) * ep.image_size * 3;
    ep.images.assign(bytes * n, 0);
    for (auto& [t, m] : p.obs) {
      auto it = p.images.find(m->header.stamp);
      if (it == p.images.end()) continue;
      const std::string bad = CheckRgbImage(*it->second, ep.image_size);
      if (!bad.empty()) {
        ++report->bad_images;
        ep.problems.push_back(who + "image at step " + std::to_string(t) + ": " + bad);
        continue;
      }
      std::memcpy(ep.images.data() + bytes * t, it->second->data.data(), bytes);
      ep.has_image[t] = 1;
    }
  }
  if (!ep.has_meta) ep.problems.push_back(who + std::string("no message on ") + kEpisodeTopic);
  std::string miss = DescribeMissing(ep.has_obs, n, &report->missing_observations);
  if (!miss.empty()) ep.problems.push_back(who + "missing observations: " + miss);
  miss = DescribeMissing(ep.has_action, n, &report->missing_actions);
  if (!miss.empty()) ep.problems.push_back(who + "missing actions: " + miss);
  if (ep.image_size > 0) {
    miss = DescribeMissing(ep.has_image, n, &report->missing_images);
    if (!miss.empty()) ep.problems.push_back(who + "missing images: " + miss);
  }
  if (p.duplicates > 0)
    ep.problems.push_back(who + std::to_string(p.duplicates) +
                          " conflicting duplicate messages (first kept)");
  report->duplicates += p.duplicates;
  report->episodes += 1;
  report->steps += static_cast<uint64_t>(n);
  if (ep.problems.empty()) report->complete_episodes += 1;
  for (auto& s : ep.problems) report->problems.push_back(s);
  return ep;
}

}  // namespace

DatasetBagReader::DatasetBagReader(std::string path)
    : path_(std::move(path)), bag_(std::make_unique<rosbag::Bag>()) {
  BagStructureCheck(path_).Run();
  try {
    bag_->open(path_, rosbag::bagmode::Read);
  } catch (const rosbag::BagException& e) {
    throw BagError(path_ + ": cannot open as a rosbag: " + e.what() +
                   " (not a bag, or truncated; a recording cut short may be repaired with"
                   " 'rosbag reindex')");
  }
}

DatasetBagReader::~DatasetBagReader() = default;

uint64_t DatasetBagReader::CountObservations() const {
  try {
    return rosbag::View(*bag_, rosbag::TopicQuery(std::vector<std::string>{kObservationTopic})).size();
  } catch (const rosbag::BagException& e) {
    throw BagError(path_ + ": cannot read the bag index: " + e.what());
  }
}

void DatasetBagReader::ForEachEpisode(const std::function<void(BagEpisode&&)>& fn) {
  report_ = BagReadReport{};
  std::map<uint32_t, PartialEpisode> open;
  uint32_t max_id = 0;
  bool any = false;
  std::map<ros::Time, uint32_t> stamp_owner;  // observation stamp -> episode id
  std::map<ros::Time, sensor_msgs::Image::ConstPtr> pending_images;  // image before its obs
  // Episodes two ids behind the newest are complete: live recordings can interleave
  // the tail of one episode with the head of the next, never more.
  bool in_callback = false;  // exceptions of fn pass through unchanged
  auto flush = [&](bool all) {
    while (!open.empty() && (all || open.begin()->first + 2 <= max_id)) {
      auto node = open.extract(open.begin());
      for (auto& kv : node.mapped().obs) stamp_owner.erase(kv.second->header.stamp);
      BagEpisode ep = Finalize(std::move(node.mapped()), &report_);
      in_callback = true;
      fn(std::move(ep));
      in_callback = false;
    }
  };
  // A step index beyond kMaxEpisodeSteps is rejected as it is read.
  auto step_ok = [&](uint32_t id, uint32_t step, const char* what) {
    if (step < kMaxEpisodeSteps) return true;
    ++report_.out_of_range_steps;
    report_.problems.push_back("episode " + std::to_string(id) + ": " + what + " step " +
                               std::to_string(step) + " out of range (limit " +
                               std::to_string(kMaxEpisodeSteps) + " steps)");
    return false;
  };
  auto slot = [&](uint32_t id) -> PartialEpisode& {
    auto& p = open[id];
    p.ep.meta.episode_id = id;
    if (!any || id > max_id) max_id = id;
    any = true;
    return p;
  };
  try {
    rosbag::View view(
        *bag_, rosbag::TopicQuery({kEpisodeTopic, kObservationTopic, kActionTopic, kImageTopic}));
    if (view.size() == 0)
      throw BagError(path_ + ": no messages on " + kObservationTopic + " / " + kActionTopic +
                     " (not an msspr dataset bag?)");
    for (const rosbag::MessageInstance& m : view) {
      ++report_.messages;
      const std::string& topic = m.getTopic();
      if (topic == kObservationTopic) {
        auto o = Instantiate<msspr::Observation>(m, "H44ff11", path_, report_.messages);
        if (!o) {
          ++report_.foreign_messages;
          continue;
        }
        if (!step_ok(o->episode_id, o->step, "observation")) continue;
        auto& p = slot(o->episode_id);
        auto [it_o, fresh] = p.obs.emplace(o->step, o);
        if (!fresh && it_o->second->state != o->state) ++p.duplicates;  // re-sends are identical
        stamp_owner[o->header.stamp] = o->episode_id;
        auto it = pending_images.find(o->header.stamp);
        if (it != pending_images.end()) {
          p.images.emplace(it->first, it->second);
          pending_images.erase(it);
        }
      } else if (topic == kActionTopic) {
        auto a = Instantiate<msspr::Action>(m, "H44f", path_, report_.messages);
        if (!a) {
          ++report_.foreign_messages;
          continue;
        }
        if (!step_ok(a->episode_id, a->step, "action")) continue;
        auto& p = slot(a->episode_id);
        auto [it_a, fresh] = p.actions.emplace(a->step, a);
        if (!fresh && it_a->second->action != a->action) ++p.duplicates;
      } else if (topic == kEpisodeTopic) {
        auto e = Instantiate<msspr::EpisodeInfo>(m, "H4ss48ff", path_, report_.messages);
        if (!e) {
          ++report_.foreign_messages;
          continue;
        }
        auto& p = slot(e->episode_id);
        p.ep.has_meta = true;
        p.ep.meta.env = e->env;
        p.ep.meta.split = e->split.empty() ? "train" : e->split;
        p.ep.meta.task_id = e->task_id;
        p.ep.meta.seed = e->seed;
        p.ep.meta.start = e->start;
        p.ep.meta.goal = e->goal;
      } else if (topic == kImageTopic) {
        auto img = Instantiate<sensor_msgs::Image>(m, "H44s14b", path_, report_.messages);
        if (!img) {
          ++report_.foreign_messages;
          continue;
        }
        // The image shares its stamp with its observation; it may come first.
        auto owner = stamp_owner.find(img->header.stamp);
        if (owner != stamp_owner.end() && open.count(owner->second))
          open[owner->second].images.emplace(img->header.stamp, img);
        else
          pending_images.emplace(img->header.stamp, img);
      }
      flush(false);
    }
  } catch (const std::exception& e) {
    // rosbag errors, corrupt messages, and deserialization errors (ros::Exception);
    // the episodes read so far are delivered first.
    if (in_callback) throw;
    const bool named = dynamic_cast<const BagError*>(&e) != nullptr;
    const std::string what = e.what();
    try {
      flush(true);
    } catch (...) {
      if (in_callback) throw;
    }
    if (named) throw BagError(what);
    throw BagError(path_ + ": truncated or corrupt after " + std::to_string(report_.messages) +
                   " messages: " + what);
  }
  flush(true);
  if (!pending_images.empty())
    report_.problems.push_back(std::to_string(pending_images.size()) +
                               " images match no observation stamp");
  if (report_.foreign_messages > 0)
    report_.problems.push_back(std::to_string(report_.foreign_messages) +
                               " messages of an unexpected type on msspr topics");
}

}  // namespace msspr::ros_bridge
