"""The C heap keeps freed blocks for reuse (``lookalike.heap``)."""

import os
import platform
import subprocess
import sys

import pytest

from lookalike import heap

_FAULTS_OF_A_SECOND_BLOCK = """
import resource
import torch
import lookalike.heap
lookalike.heap.keep_freed_memory()  # as the lookalike command does, and a library user may
def touch(megabytes):
    block = torch.empty(megabytes << 18)  # above glibc's largest mmap threshold (32 MB)
    block.fill_(1.0)
touch(64)
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
touch(48)  # fits in the freed block whatever small allocations have been carved out of it
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


def _faults(env_heap: str | None) -> int:
    env = {key: value for key, value in os.environ.items() if key != "LOOKALIKE_HEAP"}
    env |= {"LOOKALIKE_HEAP": env_heap} if env_heap else {}
    done = subprocess.run([sys.executable, "-c", _FAULTS_OF_A_SECOND_BLOCK], env=env, capture_output=True, text=True,
                          check=True)
    return int(done.stdout.split()[-1])


@pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="the setting is glibc's mallopt")
def test_a_freed_large_block_is_reused_without_page_faults():
    pages = (48 << 20) // 4096
    assert _faults("system") > pages // 2  # the C library's default: fresh pages every time
    assert _faults(None) < pages // 100


def test_the_system_heap_can_be_kept(monkeypatch):
    monkeypatch.setattr(heap, "_applied", False)  # whatever an earlier test of this process set
    assert heap.keep_freed_memory({"LOOKALIKE_HEAP": "system"}) is False
