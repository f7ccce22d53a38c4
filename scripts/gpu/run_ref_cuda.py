"""Runs the eager PyTorch reference (../shared/tools/mspr_ref.py beside the
repository, or the file $MSSPR_REFERENCE names) on CUDA: default device cuda,
then its main. Used by scripts/gpu/build_and_bench.sh (stage "ref").

    python3 scripts/gpu/run_ref_cuda.py [args of mspr_ref.py]
    (default: --time_only --scale paper --steps 220 --episodes 100)
"""
import importlib.util
import os
import sys

import torch

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
REFERENCE = os.environ.get('MSSPR_REFERENCE') or os.path.join(ROOT, '..', 'shared', 'tools', 'mspr_ref.py')

if __name__ == '__main__':
    if not os.path.isfile(REFERENCE):
        sys.exit(f'run_ref_cuda.py: no reference at {REFERENCE} (set MSSPR_REFERENCE=PATH/mspr_ref.py)')
    if not torch.cuda.is_available():
        sys.exit('run_ref_cuda.py: no CUDA device')
    spec = importlib.util.spec_from_file_location('mspr_ref', REFERENCE)
    mspr_ref = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mspr_ref)
    torch.set_default_device('cuda')
    args = sys.argv[1:] or ['--time_only', '--scale', 'paper', '--steps', '220', '--episodes', '100']
    sys.argv = [REFERENCE] + args
    mspr_ref.main()
