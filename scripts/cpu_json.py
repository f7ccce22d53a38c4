#!/usr/bin/env python3
"""Prints this machine's CPU as JSON, from lscpu: model name, vendor, family, model, logical
CPUs and the flags that decide the trainer's speed (the fields msspr_train writes to
host.yaml). The bench scripts put it into every JSON they write."""
import json
import subprocess

FLAGS = ('avx2', 'fma', 'avx512f', 'avx512_bf16', 'amx_bf16', 'amx_tile', 'avx512_fp16')


def lscpu():
    info = {}
    try:
        text = subprocess.run(['lscpu'], capture_output=True, text=True, check=False).stdout
    except OSError:
        return info
    for line in text.splitlines():
        key, _, value = line.partition(':')
        key, value = key.strip(), value.strip()
        number = int(value) if value.isdigit() else value
        if key == 'Model name':
            info['model_name'] = value
        elif key == 'Vendor ID':
            info['vendor'] = value
        elif key == 'CPU family':
            info['family'] = number
        elif key == 'Model':
            info['model'] = number
        elif key == 'CPU(s)':
            info['logical_cpus'] = number
        elif key == 'Flags':
            have = set(value.split())
            info['flags'] = [f for f in FLAGS if f in have]
    return info


if __name__ == '__main__':
    print(json.dumps(lscpu()))
