// The main() of msspr's LibTorch-linked gtests: the test process runs in the environment every
// msspr tool gives itself (msspr_core/process_env.h: OMP_WAIT_POLICY=PASSIVE, and OpenBLAS's
// own kernels for the CPU where it would otherwise pick its generic ones), so that a test
// times and computes what a user's run does. On an Intel Xeon that OpenBLAS 0.3.21 does not
// know (family 6, model 207), the generic Prescott sgemm took 41% of a small training step,
// and a learning test ran 2.3x slower than under SkylakeX's kernels.
// scripts/run_tests.sh sets both variables for the whole run, so that ctest's processes
// start once; a test run by hand re-executes itself here with them.
#include <gtest/gtest.h>

#include "msspr_core/process_env.h"

int main(int argc, char** argv) {
  msspr::core::ReexecWithToolEnvironment(argv);
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
