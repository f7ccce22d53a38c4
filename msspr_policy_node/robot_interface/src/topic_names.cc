#include "msspr_robot_interface/topic_names.h"

#include <algorithm>
#include <map>
#include <stdexcept>

namespace msspr::ros_bridge {

std::string NormalizeNamespace(const std::string& ns) {
  std::string out = "/";
  for (char c : ns) {
    if (c == '/' && out.back() == '/') continue;
    out += c;
  }
  if (out.size() > 1 && out.back() == '/') out.pop_back();
  return out;
}

std::string ResolveTopicName(const std::string& ns, const std::string& name) {
  if (!name.empty() && name[0] == '/') return NormalizeNamespace(name);
  const std::string n = NormalizeNamespace(ns);
  return NormalizeNamespace(n + "/" + name);
}

namespace {

std::string Join(const std::vector<std::string>& v) {
  std::string out;
  for (const auto& s : v) out += (out.empty() ? "" : ", ") + s;
  return out;
}

// The names of `names` that do not resolve to a topic of the bag under `ns`.
std::vector<std::string> Missing(const std::vector<std::string>& names,
                                 const std::set<std::string>& bag_topics, const std::string& ns) {
  std::vector<std::string> out;
  for (const auto& n : names)
    if (!bag_topics.count(ResolveTopicName(ns, n))) out.push_back(ResolveTopicName(ns, n));
  return out;
}

}  // namespace

TopicResolution ResolveSpecTopics(const std::vector<std::string>& names,
                                  const std::set<std::string>& bag_topics, const std::string& ns) {
  TopicResolution r;
  std::vector<std::string> relative;
  for (const auto& n : names)
    if (n.empty() || n[0] != '/') relative.push_back(n);
  if (!ns.empty() || relative.empty()) {
    r.ns = NormalizeNamespace(ns);
  } else if (Missing(relative, bag_topics, "/").empty()) {
    r.ns = "/";
  } else {
    // Candidates: every prefix P of a bag topic P/NAME for a relative NAME of the spec.
    std::map<std::string, int> held;  // namespace -> relative names it holds
    held["/"] = static_cast<int>(relative.size() - Missing(relative, bag_topics, "/").size());
    for (const auto& n : relative) {
      const std::string suffix = NormalizeNamespace(n);  // "/gripper/joint_states"
      std::set<std::string> seen;
      for (const auto& t : bag_topics) {
        if (t.size() <= suffix.size() ||
            t.compare(t.size() - suffix.size(), suffix.size(), suffix) != 0)
          continue;
        const std::string prefix = NormalizeNamespace(t.substr(0, t.size() - suffix.size()));
        if (seen.insert(prefix).second) ++held[prefix];
      }
    }
    std::vector<std::string> full;
    std::string best;
    int best_count = 0;
    for (const auto& [prefix, count] : held) {
      if (count == static_cast<int>(relative.size())) full.push_back(prefix);
      if (count > best_count) best = prefix, best_count = count;
    }
    // A namespace inside another that holds the whole spec too (/ns/gripper beside /ns, when
    // the spec reads only joint_states) is not a candidate: the outer one wins.
    auto inside = [](const std::string& inner, const std::string& outer) {
      return inner != outer && (outer == "/" || inner.rfind(outer + "/", 0) == 0);
    };
    std::vector<std::string> outermost;
    for (const auto& c : full)
      if (std::none_of(full.begin(), full.end(),
                       [&](const std::string& o) { return inside(c, o); }))
        outermost.push_back(c);
    full = outermost;
    if (full.size() > 1)
      throw std::invalid_argument(
          "the recording holds the spec's topics under several namespaces (" + Join(full) +
          "): name one with --ns or the spec's namespace: key");
    if (full.empty() && (best.empty() || best == "/"))
      throw std::invalid_argument("the recording has no topic " +
                                  Join(Missing(relative, bag_topics, "/")));
    if (full.empty()) {
      const std::string where = best;
      throw std::invalid_argument("the recording has no topic " +
                                  Join(Missing(relative, bag_topics, where)) +
                                  " (the spec's other topics are under " + where +
                                  "; another namespace is given with --ns or the spec's "
                                  "namespace: key)");
    }
    r.ns = full[0];
    r.inferred = true;
  }
  const std::vector<std::string> missing = Missing(names, bag_topics, r.ns);
  if (!missing.empty())
    throw std::invalid_argument("the recording has no topic " + Join(missing) +
                                (r.ns == "/" ? std::string() : " (namespace " + r.ns + ")"));
  for (const auto& n : names) r.topics.push_back(ResolveTopicName(r.ns, n));
  return r;
}

}  // namespace msspr::ros_bridge
