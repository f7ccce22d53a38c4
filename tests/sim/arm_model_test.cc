#include "msspr_sim/arm_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include "cube_test_util.h"

namespace msspr::sim {
namespace {

std::string ReadFile(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// `text` with the first occurrence of `from` replaced by `to`.
std::string Edited(std::string text, const std::string& from, const std::string& to) {
  const size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << "the test's edit does not apply: " << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

// The shipped URDF with the first occurrence of `from` replaced by `to`.
std::string Edited(const std::string& from, const std::string& to) {
  return Edited(ReadFile(testing_util::ArmUrdfPath()), from, to);
}

// The message of the UrdfError that parsing `text` (named `source`) throws.
std::string ParseError(const std::string& text, const std::string& source) {
  try {
    ArmModel::FromString(text, source);
  } catch (const UrdfError& e) {
    return e.what();
  }
  ADD_FAILURE() << source << " was accepted";
  return "";
}

Eigen::VectorXd Home(const ArmModel& arm) {
  Eigen::VectorXd q = Eigen::VectorXd::Zero(arm.num_dofs());
  q.head<6>() << -M_PI / 2, -M_PI / 2, M_PI / 2, -M_PI / 2, -M_PI / 2, 0;
  return q;
}

TEST(ArmModelTest, ParsesTheShippedUrdf) {
  const ArmModel arm = ArmModel::FromFile(testing_util::ArmUrdfPath());
  EXPECT_EQ(arm.source(), testing_util::ArmUrdfPath());
  EXPECT_EQ(arm.links()[0].name, "world");
  ASSERT_EQ(arm.arm_joint_links().size(), 6u);
  const char* names[] = {"shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
                         "wrist_1_joint",      "wrist_2_joint",       "wrist_3_joint"};
  for (int i = 0; i < 6; ++i) {
    const auto& l = arm.links()[arm.arm_joint_links()[i]];
    EXPECT_EQ(l.joint, names[i]);
    EXPECT_EQ(l.dof, i);
    const double limit = i == 2 ? 3.1415 : 6.28319;  // manipulation.md, section 2
    EXPECT_DOUBLE_EQ(l.lower, -limit) << l.joint;
    EXPECT_DOUBLE_EQ(l.upper, limit) << l.joint;
  }
  EXPECT_EQ(arm.num_dofs(), 7);
  EXPECT_EQ(arm.links()[arm.gripper_link()].joint, "left_finger_joint");
  EXPECT_EQ(arm.links()[arm.tip_link()].name, "pinch");
  EXPECT_EQ(arm.links()[arm.flange_link()].name, "flange");
  const auto& right = arm.links()[arm.LinkIndex("right_finger")];
  EXPECT_TRUE(right.mimic);
  EXPECT_EQ(right.dof, 6);
  for (size_t l = 1; l < arm.links().size(); ++l)
    EXPECT_LT(arm.links()[l].parent, static_cast<int>(l)) << "parents must precede children";
  EXPECT_THROW(arm.LinkIndex("no_such_link"), std::out_of_range);
}

// OGBench's home pose puts the pinch at (0.492, 0.134, 0.332), pointing
// straight down with yaw 0 (manipulation.md, section 1; 3 decimals given).
TEST(ArmModelTest, HomePoseIsOgbenchs) {
  const ArmModel arm = ArmModel::FromFile(testing_util::ArmUrdfPath());
  const Eigen::Isometry3d pinch = arm.LinkPose(arm.tip_link(), Home(arm));
  std::printf("pinch at home: (%.4f, %.4f, %.4f)\n", pinch.translation().x(),
              pinch.translation().y(), pinch.translation().z());
  EXPECT_NEAR(pinch.translation().x(), 0.492, 5e-4);
  EXPECT_NEAR(pinch.translation().y(), 0.134, 5e-4);
  EXPECT_NEAR(pinch.translation().z(), 0.332, 5e-4);
  // "Pointing down, yaw 0" is OGBench's target orientation Rz(0) Rx(pi).
  const Eigen::Matrix3d down = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix();
  EXPECT_LT((pinch.linear() - down).norm(), 1e-9) << pinch.linear();
}

// Pinch relative to flange: 0.1558 m along the tool axis, and the flange is
// Rz(+90) from the pinch (manipulation.md, section 2), at any configuration.
TEST(ArmModelTest, PinchIsFixedToTheFlange) {
  const ArmModel arm = ArmModel::FromFile(testing_util::ArmUrdfPath());
  std::mt19937_64 rng(7);
  const Eigen::VectorXd lo = arm.LowerLimits(), hi = arm.UpperLimits();
  for (int k = 0; k < 5; ++k) {
    Eigen::VectorXd q(arm.num_dofs());
    for (int i = 0; i < q.size(); ++i)
      q[i] = std::uniform_real_distribution<double>(lo[i], hi[i])(rng);
    const Eigen::Isometry3d pinch_to_flange =
        arm.LinkPose(arm.tip_link(), q).inverse() * arm.LinkPose(arm.flange_link(), q);
    EXPECT_LT((pinch_to_flange.translation() - Eigen::Vector3d(0, 0, -0.1558)).norm(), 1e-12);
    const Eigen::Matrix3d rz90 =
        Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    EXPECT_LT((pinch_to_flange.linear() - rz90).norm(), 1e-12);
  }
}

// The pads' inner faces are 85 mm apart when open and meet at the pinch
// point when closed; the pads stay centred on the pinch point's y.
TEST(ArmModelTest, FingersOpenTo85Millimetres) {
  const ArmModel arm = ArmModel::FromFile(testing_util::ArmUrdfPath());
  const int left = arm.LinkIndex("left_finger"), right = arm.LinkIndex("right_finger");
  const double pad_half_thickness = 0.004;
  for (double travel : {0.0, 0.02, 0.0425}) {
    Eigen::VectorXd q = Home(arm);
    q[6] = travel;
    const Eigen::Isometry3d pinch_inv = arm.LinkPose(arm.tip_link(), q).inverse();
    const Eigen::Vector3d l = pinch_inv * arm.LinkPose(left, q).translation();
    const Eigen::Vector3d r = pinch_inv * arm.LinkPose(right, q).translation();
    EXPECT_NEAR(l.y() - r.y() - 2 * pad_half_thickness, 0.085 - 2 * travel, 1e-12);
    EXPECT_NEAR(l.y() + r.y(), 0.0, 1e-12);
    EXPECT_NEAR(l.x(), 0.0, 1e-12);
    EXPECT_NEAR(l.z(), 0.0, 1e-12);
    EXPECT_NEAR(r.z(), 0.0, 1e-12);
  }
}

TEST(ArmModelTest, LinkPosesAgreesWithLinkPose) {
  const ArmModel arm = ArmModel::FromFile(testing_util::ArmUrdfPath());
  Eigen::VectorXd q(arm.num_dofs());
  q << 0.3, -1.1, 0.7, -2.0, 1.4, 2.5, 0.01;
  const auto poses = arm.LinkPoses(q);
  ASSERT_EQ(poses.size(), arm.links().size());
  for (size_t l = 0; l < poses.size(); ++l)
    EXPECT_LT((poses[l].matrix() - arm.LinkPose(static_cast<int>(l), q).matrix()).norm(), 1e-12);
  EXPECT_THROW(arm.LinkPose(arm.tip_link(), Eigen::VectorXd::Zero(6)), std::invalid_argument);
}

TEST(ArmModelTest, UnreadableFileIsNamed) {
  const std::string path = std::string(MSSPR_TEST_TMPDIR) + "/no_such_dir/arm.urdf";
  try {
    ArmModel::FromFile(path);
    FAIL() << "a missing file was accepted";
  } catch (const UrdfError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("cannot open"), std::string::npos) << e.what();
  }
}

// Each bad input names the source and the element at fault.
struct BadCase {
  const char* label;
  std::string text;
  std::vector<std::string> expected;  // substrings of the message
};

TEST(ArmModelTest, BadUrdfGivesClearErrors) {
  const std::vector<BadCase> cases = {
      {"not_xml", "<robot name='x'><link name='a'>", {"not_xml.urdf", "urdfdom"}},
      {"missing_link",
       Edited("<child link=\"forearm_link\"/>", "<child link=\"forearm_lnk\"/>"),
       {"missing_link.urdf", "forearm_lnk"}},
      {"bad_type",
       Edited("<joint name=\"elbow_joint\" type=\"revolute\">",
              "<joint name=\"elbow_joint\" type=\"hinge\">"),
       {"bad_type.urdf", "elbow_joint", "hinge"}},
      {"continuous",
       Edited("<joint name=\"elbow_joint\" type=\"revolute\">",
              "<joint name=\"elbow_joint\" type=\"continuous\">"),
       {"continuous.urdf", "joint 'elbow_joint'", "continuous", "not supported"}},
      {"missing_limit",
       Edited("<limit lower=\"-3.1415\" upper=\"3.1415\" effort=\"150\" velocity=\"3.14\"/>", ""),
       {"missing_limit.urdf", "elbow_joint", "limits"}},
      {"empty_range",
       Edited("<limit lower=\"-3.1415\" upper=\"3.1415\"", "<limit lower=\"0\" upper=\"0\""),
       {"empty_range.urdf", "joint 'elbow_joint'", "lower < upper"}},
      {"no_pinch",
       Edited(Edited("<link name=\"pinch\"/>", "<link name=\"tcp\"/>"), "<child link=\"pinch\"/>",
              "<child link=\"tcp\"/>"),
       {"no_pinch.urdf", "no link 'pinch'"}},
      {"bad_mimic",
       Edited("<mimic joint=\"left_finger_joint\"", "<mimic joint=\"nope_joint\""),
       {"bad_mimic.urdf", "joint 'right_finger_joint'", "nope_joint"}},
      {"zero_axis",
       Edited("<axis xyz=\"0 1 0\"/>", "<axis xyz=\"0 0 0\"/>"),
       {"zero_axis.urdf", "shoulder_lift_joint"}},
      {"two_grippers",
       Edited("    <mimic joint=\"left_finger_joint\" multiplier=\"1\" offset=\"0\"/>\n", ""),
       {"two_grippers.urdf", "right_finger_joint", "second independent gripper joint"}},
  };
  for (const BadCase& c : cases) {
    const std::string source = std::string(c.label) + ".urdf";
    const std::string message = ParseError(c.text, source);
    std::printf("%s\n", message.c_str());
    for (const auto& part : c.expected)
      EXPECT_NE(message.find(part), std::string::npos)
          << c.label << ": '" << part << "' missing from: " << message;
  }
  // A file with an error is named by its path.
  const std::filesystem::path dir = MSSPR_TEST_TMPDIR;
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "bad_type_file.urdf").string();
  std::ofstream(path) << Edited("type=\"revolute\"", "type=\"floating\"");
  try {
    ArmModel::FromFile(path);
    FAIL() << "a floating arm joint was accepted";
  } catch (const UrdfError& e) {
    const std::string m = e.what();
    EXPECT_EQ(m.rfind(path + ": ", 0), 0u) << m;
    EXPECT_NE(m.find("joint 'shoulder_pan_joint'"), std::string::npos) << m;
  }
}

}  // namespace
}  // namespace msspr::sim
