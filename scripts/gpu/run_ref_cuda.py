"""Runs the eager PyTorch reference (scripts/gpu/mspr_ref.py, a copy of
../shared/tools/mspr_ref.py) on CUDA: default device cuda, then its main.

    python3 scripts/gpu/run_ref_cuda.py [args of mspr_ref.py]
    (default: --time_only --scale paper --steps 220 --episodes 100)
"""
import os
import sys

import torch

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import mspr_ref  # noqa: E402

if __name__ == '__main__':
    if not torch.cuda.is_available():
        sys.exit('run_ref_cuda.py: no CUDA device')
    torch.set_default_device('cuda')
    args = sys.argv[1:] or ['--time_only', '--scale', 'paper', '--steps', '220', '--episodes', '100']
    sys.argv = [mspr_ref.__file__] + args
    mspr_ref.main()
