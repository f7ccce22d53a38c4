// Process environment for the tools. No torch.
#pragma once

namespace msspr {
namespace core {

// LibTorch's CPU ops run on OpenMP threads whose default wait policy spins.
// On cores shared with other processes a spinning thread waits for a
// descheduled one, and a training step took 7.8 s instead of 0.19 s (2
// threads, 2 busy cores; OMP_WAIT_POLICY=PASSIVE restores 0.19 s). libgomp
// reads the variable once at load time, so when OMP_WAIT_POLICY is unset this
// sets it to PASSIVE and re-executes the program (/proc/self/exe) with the
// same arguments. Returns only when nothing was re-executed (variable
// already set, or exec failed).
void ReexecWithPassiveOpenMpWait(char** argv);

}  // namespace core
}  // namespace msspr
