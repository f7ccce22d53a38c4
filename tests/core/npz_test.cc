#include "msspr_core/npz.h"

#include <gtest/gtest.h>

#include <string>

#include "test_util.h"

namespace msspr {
namespace core {
namespace {

using testing_util::HaveNumpy;
using testing_util::RunPython;
using testing_util::TempDir;
using testing_util::WriteText;

// Three trajectories of lengths 3, 4, 5 (N = 12), written by numpy.
const char kWriteScript[] = R"(
import numpy as np, sys
d = sys.argv[1] if len(sys.argv) > 1 else '%DIR%'
lengths = [3, 4, 5]
n = sum(lengths)
obs = np.arange(n * 2, dtype=np.float32).reshape(n, 2)
act = (np.arange(n * 3, dtype=np.float32).reshape(n, 3) / 100.0).astype(np.float32)
term = np.zeros(n, dtype=np.float32)
term[np.cumsum(lengths) - 1] = 1.0
np.savez(d + '/plain.npz', observations=obs, actions=act, terminals=term)
np.savez_compressed(d + '/compressed.npz', observations=obs, actions=act, terminals=term,
                    qpos=obs)
np.savez(d + '/float64.npz', observations=obs.astype(np.float64), actions=act,
         terminals=term.astype(bool))
img = (np.arange(n * 64 * 64 * 3) % 251).astype(np.uint8).reshape(n, 64, 64, 3)
np.savez_compressed(d + '/visual.npz', observations=img, actions=act, terminals=term)
np.savez(d + '/noactions.npz', observations=obs, terminals=term)
np.savez(d + '/badterminals.npz', observations=obs, actions=act, terminals=term[:5])
np.savez(d + '/badactions.npz', observations=obs, actions=act[:, :, None], terminals=term)
)";

std::string Script(const std::string& dir) {
  std::string s = kWriteScript;
  const std::string key = "%DIR%";
  s.replace(s.find(key), key.size(), dir);
  return s;
}

class NpzTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!HaveNumpy()) GTEST_SKIP() << "/usr/bin/python3 lacks numpy";
    ASSERT_EQ(RunPython(Script(dir_.path()), dir_.path()), 0);
  }
  TempDir dir_;
};

void ExpectStateDataset(const Dataset& d) {
  ASSERT_EQ(d.size(), 12);
  EXPECT_EQ(d.obs_dim(), 2);
  EXPECT_EQ(d.action_dim(), 3);
  EXPECT_EQ(d.num_trajectories(), 3);
  EXPECT_EQ(d.trajectory_starts(), (std::vector<int64_t>{0, 3, 7}));
  EXPECT_EQ(d.trajectory_ends(), (std::vector<int64_t>{2, 6, 11}));
  EXPECT_FLOAT_EQ(d.state(5)[1], 11.0f);
  EXPECT_FLOAT_EQ(d.action(4)[2], 0.14f);
}

TEST_F(NpzTest, LoadsPlainAndCompressed) {
  ExpectStateDataset(LoadNpzDataset(dir_.File("plain.npz")));
  ExpectStateDataset(LoadNpzDataset(dir_.File("compressed.npz")));
  ExpectStateDataset(LoadNpzDataset(dir_.File("float64.npz")));
  const auto keys = ListNpzKeys(dir_.File("compressed.npz"));
  EXPECT_EQ(keys.size(), 4u);
}

TEST_F(NpzTest, LoadsUint8Images) {
  const Dataset d = LoadNpzDataset(dir_.File("visual.npz"));
  ASSERT_EQ(d.size(), 12);
  EXPECT_FALSE(d.has_states());
  ASSERT_TRUE(d.has_images());
  EXPECT_EQ(d.image_shape().height, 64);
  EXPECT_EQ(d.image_shape().width, 64);
  EXPECT_EQ(d.image_shape().channels, 3);
  EXPECT_EQ(d.num_trajectories(), 3);
  const int64_t flat = 5 * 64 * 64 * 3 + 7;
  EXPECT_EQ(d.image(5)[7], flat % 251);
}

void ExpectErrorNames(const std::string& path, const std::string& key) {
  try {
    LoadNpzDataset(path);
    FAIL() << "no exception for " << path;
  } catch (const NpzError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(path), std::string::npos) << msg;
    if (!key.empty()) {
      EXPECT_NE(msg.find("'" + key + "'"), std::string::npos) << msg;
    }
  }
}

TEST_F(NpzTest, MalformedFilesNameFileAndKey) {
  ExpectErrorNames(dir_.File("noactions.npz"), "actions");
  ExpectErrorNames(dir_.File("badterminals.npz"), "terminals");
  ExpectErrorNames(dir_.File("badactions.npz"), "actions");
  ExpectErrorNames(dir_.File("missing.npz"), "");
  WriteText(dir_.File("garbage.npz"), "this is not a zip file at all");
  ExpectErrorNames(dir_.File("garbage.npz"), "");
  // A truncated archive.
  const std::string full = testing_util::ReadText(dir_.File("plain.npz"));
  WriteText(dir_.File("truncated.npz"), full.substr(0, full.size() / 2));
  ExpectErrorNames(dir_.File("truncated.npz"), "");
}

// Hostile files: NaN / Inf, a header that lies about the shape, negative and
// overflowing dimensions, a truncated entry. Each fails with NpzError naming
// the file (and the array), never with a huge allocation or a std:: error.
const char kHostileScript[] = R"(
import numpy as np, zipfile, io, sys
d = sys.argv[1] if len(sys.argv) > 1 else '%DIR%'
n = 12
obs = np.arange(n * 2, dtype=np.float32).reshape(n, 2)
act = np.zeros((n, 3), dtype=np.float32)
term = np.zeros(n, dtype=np.float32); term[-1] = 1
bad = obs.copy(); bad[4, 1] = np.nan; bad[7, 0] = np.inf
np.savez(d + '/nan_obs.npz', observations=bad, actions=act, terminals=term)
bad_act = act.copy(); bad_act[2, 2] = -np.inf
np.savez(d + '/inf_act.npz', observations=obs, actions=bad_act, terminals=term)
def npy(shape_text, payload, descr='<f4'):
    h = "{'descr': '%s', 'fortran_order': False, 'shape': %s, }" % (descr, shape_text)
    h += ' ' * ((64 - (10 + len(h) + 1) % 64) % 64) + '\n'
    return b'\x93NUMPY\x01\x00' + len(h).to_bytes(2, 'little') + h.encode() + payload
def write(name, obs_entry):
    with zipfile.ZipFile(d + '/' + name, 'w') as z:
        z.writestr('observations.npy', obs_entry)
        z.writestr('actions.npy', npy('(12, 3)', act.tobytes()))
        z.writestr('terminals.npy', npy('(12,)', term.tobytes()))
write('lying.npz', npy('(100000000000, 2)', obs.tobytes()))
write('short.npz', npy('(12, 2)', obs.tobytes()[:40]))
write('negative.npz', npy('(-5, 2)', obs.tobytes()))
write('overflow.npz', npy('(4611686018427387904, 4611686018427387904)', obs.tobytes()))
write('garbled.npz', npy('(12, zz)', obs.tobytes()))
)";

TEST_F(NpzTest, HostileFilesFailNamingFileAndArray) {
  std::string s = kHostileScript;
  s.replace(s.find("%DIR%"), 5, dir_.path());
  ASSERT_EQ(RunPython(s, dir_.path()), 0);
  for (const char* name : {"lying.npz", "short.npz", "negative.npz", "overflow.npz", "garbled.npz"})
    ExpectErrorNames(dir_.File(name), "observations");
  ExpectErrorNames(dir_.File("nan_obs.npz"), "observations");
  ExpectErrorNames(dir_.File("inf_act.npz"), "actions");
  try {
    LoadNpzDataset(dir_.File("nan_obs.npz"));
  } catch (const NpzError& e) {
    EXPECT_NE(std::string(e.what()).find("2 non-finite values"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("row 4"), std::string::npos) << e.what();
  }
  try {
    LoadNpzDataset(dir_.File("lying.npz"));
  } catch (const NpzError& e) {
    EXPECT_NE(std::string(e.what()).find("header says shape"), std::string::npos) << e.what();
  }
  // The array readers name the file too.
  EXPECT_THROW(ReadNpzFloat(dir_.File("negative.npz"), "observations", nullptr), NpzError);
  EXPECT_THROW(ReadNpzFloat(dir_.File("lying.npz"), "observations", nullptr), NpzError);
  // Every prefix of a valid file: an NpzError, nothing else.
  const std::string full = testing_util::ReadText(dir_.File("plain.npz"));
  for (size_t cut : {size_t{0}, size_t{30}, full.size() / 3, full.size() - 22, full.size() - 1}) {
    WriteText(dir_.File("cut.npz"), full.substr(0, cut));
    ExpectErrorNames(dir_.File("cut.npz"), "");
  }
}

TEST_F(NpzTest, ExportRoundTripsAndNumpyReadsIt) {
  const Dataset d = LoadNpzDataset(dir_.File("compressed.npz"));
  for (bool compress : {false, true}) {
    const std::string out = dir_.File(compress ? "export_c.npz" : "export.npz");
    SaveNpzDataset(d, out, compress);
    const Dataset back = LoadNpzDataset(out);
    ExpectStateDataset(back);
    EXPECT_EQ(back.states(), d.states());
    EXPECT_EQ(back.actions(), d.actions());
    const std::string check =
        "import numpy as np\n"
        "z = np.load('" +
        out +
        "')\n"
        "assert z['observations'].shape == (12, 2) and z['observations'].dtype == np.float32\n"
        "assert z['actions'].shape == (12, 3)\n"
        "assert list(np.nonzero(z['terminals'])[0]) == [2, 6, 11]\n"
        "assert z['observations'][5, 1] == 11.0\n";
    EXPECT_EQ(RunPython(check, dir_.path()), 0) << out;
  }
  // States and images together (the core's own format).
  DatasetBuilder b(2, 1, ImageShape{64, 64, 3});
  std::vector<float> obs{0, 1, 2, 3}, act{0.5f, -0.5f};
  std::vector<uint8_t> img(2 * 64 * 64 * 3, 7);
  b.AddEpisode(obs, act, img);
  const Dataset both = b.Build();
  SaveNpzDataset(both, dir_.File("both.npz"));
  const Dataset both_back = LoadNpzDataset(dir_.File("both.npz"));
  EXPECT_TRUE(both_back.has_states());
  EXPECT_TRUE(both_back.has_images());
  EXPECT_EQ(both_back.images(), both.images());
}

}  // namespace
}  // namespace core
}  // namespace msspr
