// The translation unit that carries msspr_torch_pch_exe's precompiled <torch/torch.h>
// (msspr_torch_pch.cmake); it defines nothing.
