// Checks that the dataset bag reader (dataset_bag.h) runs before it trusts a
// byte of a bag: the file's record structure, and each message's bytes against
// the wire layout of its type.
//
// The layouts are not written down here: MessageLayout derives each one from
// the definition that the message generator compiled into the type
// (ros::message_traits::Definition, which holds msgs/msg/*.msg and the
// definitions it depends on). A field added to a .msg changes the layout with it.
#pragma once

#include <ros/message_traits.h>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace msspr::ros_bridge {

// rosbag (1.15) trusts the lengths and offsets stored in a bag: a corrupt index
// entry or record length makes it read outside its buffers and crash. This
// walks the file's records (format 2.0) and checks every length against the
// bytes that hold it, decompresses each chunk (none, lz4 or bz2: what rosbag writes) and checks
// that every index entry points at a whole record inside it. Throws BagError naming the file and
// the byte offset ("corrupt or truncated"), or the compression when a chunk uses one that rosbag
// does not write ("not supported").
void CheckBagStructure(const std::string& path);

// The wire layout of a ROS message type. The ROS deserializer sizes an array
// from its length field before checking it against the data, so a corrupt
// length would allocate gigabytes first; Fits() checks the lengths first.
class MessageLayout {
 public:
  // `definition` is the full definition text (the type's fields, then one
  // "MSG: package/Type" section per message type it uses). Throws
  // std::invalid_argument naming the type and the field it cannot lay out.
  MessageLayout(const std::string& datatype, const std::string& definition);
  ~MessageLayout();
  MessageLayout(const MessageLayout&) = delete;
  MessageLayout& operator=(const MessageLayout&) = delete;

  // The layout of the generated message type M, derived once.
  template <class M>
  static const MessageLayout& Of() {
    static const MessageLayout layout(ros::message_traits::datatype<M>(),
                                      ros::message_traits::definition<M>());
    return layout;
  }

  // Whether `n` bytes hold exactly one serialized message of this type. When
  // they do not and `why` is given, it names the field and byte where they break.
  bool Fits(const uint8_t* data, size_t n, std::string* why = nullptr) const;

  const std::string& datatype() const { return datatype_; }
  // The fields in wire order, nested messages flattened: "uint32 header.seq, ...".
  std::string Describe() const;

  struct Field;

 private:
  std::string datatype_;
  std::vector<Field> fields_;
};

}  // namespace msspr::ros_bridge
