#include "msspr_sim/cube_scene.h"

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <sstream>
#include <string>

#include "cube_test_util.h"
#include "mujoco_util.h"

namespace msspr::sim {
namespace {

using internal::DataPtr;
using internal::ModelPtr;

// Writes `xml` to a temporary file and compiles it; fails the test with
// MuJoCo's message if it does not compile.
ModelPtr Compile(const std::string& xml, const std::string& name) {
  const std::filesystem::path dir = MSSPR_TEST_TMPDIR;
  std::filesystem::create_directories(dir);
  const std::string path = (dir / (name + ".xml")).string();
  std::ofstream(path) << xml;
  char error[1024] = {0};
  ModelPtr m(mj_loadXML(path.c_str(), nullptr, error, sizeof(error)));
  EXPECT_TRUE(m) << path << ": " << error;
  return m;
}

int Id(const mjModel* m, mjtObj type, const std::string& name) {
  return mj_name2id(m, type, name.c_str());
}

class CubeSceneTest : public ::testing::Test {
 protected:
  void SetUp() override {
    xml_ = CubeSceneMjcf(arm_);
    model_ = Compile(xml_, "cube_scene");
    ASSERT_TRUE(model_);
    data_.reset(mj_makeData(model_.get()));
  }

  // Writes arm configuration q (ArmModel's dofs) into qpos, mimics included.
  void SetQpos(const Eigen::VectorXd& q) {
    for (const auto& l : arm_.links()) {
      if (l.dof < 0) continue;
      const int j = Id(model_.get(), mjOBJ_JOINT, l.joint);
      ASSERT_GE(j, 0) << l.joint;
      data_->qpos[model_->jnt_qposadr[j]] = l.multiplier * q[l.dof] + l.offset;
    }
  }

  ArmModel arm_ = ArmModel::FromFile(testing_util::ArmUrdfPath());
  std::string xml_;
  ModelPtr model_;
  DataPtr data_;
};

TEST_F(CubeSceneTest, CompilesWithTheExpectedLayout) {
  const mjModel* m = model_.get();
  EXPECT_EQ(m->nq, 6 + 2 + 7);
  EXPECT_EQ(m->nv, 6 + 2 + 6);
  EXPECT_EQ(m->nu, 7);
  EXPECT_EQ(m->nmocap, 1);
  EXPECT_EQ(m->opt.integrator, mjINT_IMPLICIT);
  EXPECT_EQ(m->opt.cone, mjCONE_ELLIPTIC);
  EXPECT_DOUBLE_EQ(m->opt.timestep, 0.002);
  EXPECT_DOUBLE_EQ(m->opt.impratio, 10.0);
  // qpos: the arm joints 0-5 in order, the fingers 6-7, the cube 8-14.
  for (int i = 0; i < 6; ++i) {
    const auto& l = arm_.links()[arm_.arm_joint_links()[i]];
    const int j = Id(m, mjOBJ_JOINT, l.joint);
    ASSERT_GE(j, 0) << l.joint;
    EXPECT_EQ(m->jnt_qposadr[j], i);
    EXPECT_DOUBLE_EQ(m->dof_armature[m->jnt_dofadr[j]], 0.1);
    // The position servo: kp (ctrl - q) - kv qdot.
    const int a = Id(m, mjOBJ_ACTUATOR, l.joint);
    ASSERT_GE(a, 0);
    const double kp[] = {4500, 4500, 4500, 2000, 2000, 500};
    const double kv[] = {400, 400, 400, 100, 100, 100};
    EXPECT_DOUBLE_EQ(m->actuator_gainprm[a * mjNGAIN], kp[i]);
    EXPECT_DOUBLE_EQ(m->actuator_biasprm[a * mjNBIAS + 1], -kp[i]);
    EXPECT_DOUBLE_EQ(m->actuator_biasprm[a * mjNBIAS + 2], -kv[i]);
    EXPECT_DOUBLE_EQ(m->actuator_forcerange[2 * a + 1], i < 3 ? 150 : 28);
  }
  EXPECT_EQ(m->jnt_qposadr[Id(m, mjOBJ_JOINT, "left_finger_joint")], 6);
  EXPECT_EQ(m->jnt_qposadr[Id(m, mjOBJ_JOINT, "right_finger_joint")], 7);
  const int cube_joint = Id(m, mjOBJ_JOINT, "object_joint_0");
  ASSERT_GE(cube_joint, 0);
  EXPECT_EQ(m->jnt_type[cube_joint], mjJNT_FREE);
  EXPECT_EQ(m->jnt_qposadr[cube_joint], 8);
  // Frames and cameras the env needs.
  EXPECT_GE(Id(m, mjOBJ_SITE, "pinch"), 0);
  EXPECT_GE(Id(m, mjOBJ_SITE, "flange"), 0);
  EXPECT_GE(Id(m, mjOBJ_BODY, "right_finger"), 0);
  EXPECT_GE(Id(m, mjOBJ_CAMERA, "front"), 0);
  EXPECT_GE(Id(m, mjOBJ_CAMERA, "front_pixels"), 0);
  EXPECT_GE(Id(m, mjOBJ_TENDON, "split"), 0);
  EXPECT_EQ(m->neq, 1);
  // The cube: 4 cm, 1240 kg/m^3.
  const int cube = Id(m, mjOBJ_BODY, "object_0");
  EXPECT_NEAR(m->body_mass[cube], 1240 * 0.04 * 0.04 * 0.04, 1e-9);
  // Walls collide with the cube, not with the arm.
  const int wall = Id(m, mjOBJ_GEOM, "wall_far");
  const int cube_geom = Id(m, mjOBJ_GEOM, "cube");
  const int pad = Id(m, mjOBJ_GEOM, "left_pad");
  ASSERT_GE(pad, 0);
  EXPECT_TRUE(m->geom_contype[cube_geom] & m->geom_conaffinity[wall]);
  EXPECT_FALSE(m->geom_contype[pad] & m->geom_conaffinity[wall]);
  EXPECT_FALSE(m->geom_contype[wall] & m->geom_conaffinity[pad]);
  EXPECT_DOUBLE_EQ(m->geom_friction[3 * pad], 0.7);
  EXPECT_EQ(m->geom_priority[pad], 1);
  // Masses come from the URDF: arm links plus the gripper.
  EXPECT_NEAR(m->body_mass[Id(m, mjOBJ_BODY, "upper_arm_link")], 8.393, 1e-12);
  EXPECT_NEAR(m->body_mass[Id(m, mjOBJ_BODY, "gripper_base")], 0.777, 1e-12);
}

// The kinematics check: forward kinematics of the urdfdom model
// (Eigen) equals MuJoCo's body and site poses after mj_kinematics, at 20
// random configurations within the joint limits.
TEST_F(CubeSceneTest, UrdfKinematicsMatchMujoco) {
  const mjModel* m = model_.get();
  std::mt19937_64 rng(20261123);
  const Eigen::VectorXd lo = arm_.LowerLimits(), hi = arm_.UpperLimits();
  double max_pos = 0, max_rot = 0;
  int compared = 0;
  for (int k = 0; k < 20; ++k) {
    Eigen::VectorXd q(arm_.num_dofs());
    for (int i = 0; i < q.size(); ++i)
      q[i] = std::uniform_real_distribution<double>(lo[i], hi[i])(rng);
    mj_resetData(m, data_.get());
    SetQpos(q);
    mj_kinematics(m, data_.get());
    const auto poses = arm_.LinkPoses(q);
    for (size_t l = 1; l < poses.size(); ++l) {
      const std::string& name = arm_.links()[l].name;
      Eigen::Vector3d pos;
      Eigen::Matrix3d rot;
      const int body = Id(m, mjOBJ_BODY, name), site = Id(m, mjOBJ_SITE, name);
      ASSERT_TRUE(body >= 0 || site >= 0) << "link " << name << " is not in the MJCF";
      // mjData's xmat / site_xmat are row-major 3x3.
      const mjtNum* p = body >= 0 ? data_->xpos + 3 * body : data_->site_xpos + 3 * site;
      const mjtNum* r = body >= 0 ? data_->xmat + 9 * body : data_->site_xmat + 9 * site;
      pos << p[0], p[1], p[2];
      rot = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(r);
      max_pos = std::max(max_pos, (pos - poses[l].translation()).norm());
      max_rot = std::max(max_rot, Eigen::AngleAxisd(rot.transpose() * poses[l].linear()).angle());
      ++compared;
    }
  }
  std::printf(
      "FK vs MuJoCo over %d link poses: max position error %.3g m, max rotation error %.3g rad\n",
      compared, max_pos, max_rot);
  EXPECT_EQ(compared, 20 * static_cast<int>(arm_.links().size() - 1));
  EXPECT_LT(max_pos, 1e-6);
  EXPECT_LT(max_rot, 1e-6);
}

// Physics sanity: the servos hold the home pose under gravity, the gripper
// closes on ctrl 255, and the cube rests on the floor.
TEST_F(CubeSceneTest, ServosHoldHomeAndTheGripperCloses) {
  const mjModel* m = model_.get();
  mjData* d = data_.get();
  const double home[] = {-M_PI / 2, -M_PI / 2, M_PI / 2, -M_PI / 2, -M_PI / 2, 0};
  for (int i = 0; i < 6; ++i) d->qpos[i] = d->ctrl[i] = home[i];
  d->ctrl[6] = 0;
  for (int t = 0; t < 500; ++t) mj_step(m, d);  // 1 s
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(d->qpos[i], home[i], 0.02) << "joint " << i;
  EXPECT_NEAR(d->qpos[6], 0.0, 1e-3);
  const int cube = Id(m, mjOBJ_BODY, "object_0");
  EXPECT_NEAR(d->xpos[3 * cube + 2], 0.02, 1e-3);
  EXPECT_NEAR(d->xpos[3 * cube + 0], 0.3, 1e-3);

  d->ctrl[6] = 255;
  for (int t = 0; t < 250; ++t) mj_step(m, d);  // 0.5 s
  // Closed: the pads meet (travel 0.0425 m less contact penetration).
  EXPECT_NEAR(d->qpos[6], 0.0425, 1e-3);
  EXPECT_NEAR(d->qpos[7], d->qpos[6], 1e-4);  // the mimic equality
  for (int i = 0; i < m->nq; ++i) ASSERT_TRUE(std::isfinite(d->qpos[i]));
}

TEST(CubeSceneErrorTest, MeshGeometryIsRejectedWithTheLink) {
  std::ifstream in(testing_util::ArmUrdfPath());
  std::ostringstream s;
  s << in.rdbuf();
  std::string text = s.str();
  const std::string from = "<geometry><cylinder radius=\"0.04\" length=\"0.04\"/></geometry>";
  const size_t at = text.find(from);
  ASSERT_NE(at, std::string::npos);
  text.replace(at, from.size(), "<geometry><mesh filename=\"wrist3.obj\"/></geometry>");
  const ArmModel arm = ArmModel::FromString(text, "mesh.urdf");
  try {
    CubeSceneMjcf(arm);
    FAIL() << "a mesh was accepted";
  } catch (const UrdfError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("mesh.urdf"), std::string::npos) << msg;
    EXPECT_NE(msg.find("link 'wrist_3_link'"), std::string::npos) << msg;
    EXPECT_NE(msg.find("mesh"), std::string::npos) << msg;
  }
}

TEST(CubeSceneErrorTest, MissingPadIsNamed) {
  std::ifstream in(testing_util::ArmUrdfPath());
  std::ostringstream s;
  s << in.rdbuf();
  std::string text = s.str();
  const std::string from = "<collision name=\"right_pad\">";
  const size_t at = text.find(from);
  ASSERT_NE(at, std::string::npos);
  text.replace(at, from.size(), "<collision>");
  const ArmModel arm = ArmModel::FromString(text, "nopad.urdf");
  try {
    CubeSceneMjcf(arm);
    FAIL() << "a missing pad was accepted";
  } catch (const UrdfError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("nopad.urdf"), std::string::npos) << msg;
    EXPECT_NE(msg.find("right_pad"), std::string::npos) << msg;
  }
}

}  // namespace
}  // namespace msspr::sim
