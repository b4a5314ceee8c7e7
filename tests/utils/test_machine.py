"""The machine record a run keeps (synthcal.utils.machine)."""

import platform

import numpy as np
import torch

from synthcal.utils.machine import cpu_model, machine_record


def test_the_cpu_model_is_read_from_cpuinfo(tmp_path):
    cpuinfo = tmp_path / "cpuinfo"
    cpuinfo.write_text("processor\t: 0\nvendor_id\t: AuthenticAMD\nmodel name\t: AMD EPYC 9R14 96-Core Processor\n"
                       "processor\t: 1\nmodel name\t: AMD EPYC 9R14 96-Core Processor\n")
    assert cpu_model(cpuinfo) == "AMD EPYC 9R14 96-Core Processor"


def test_without_cpuinfo_the_platform_names_the_processor(tmp_path):
    expected = platform.processor() or platform.machine() or "unknown"
    assert cpu_model(tmp_path / "absent") == expected
    (tmp_path / "blank").write_text("processor\t: 0\nmodel name\t:\n")  # a field without a value
    assert cpu_model(tmp_path / "blank") == expected


def test_the_record_names_the_libraries_and_threads_of_this_process():
    record = machine_record()
    assert record["torch"] == torch.__version__ and record["numpy"] == np.__version__
    assert record["torch_threads"] == torch.get_num_threads()
    assert record["cpu_capability"] == torch.backends.cpu.get_cpu_capability()
    assert record["python"] == platform.python_version()
