"""Which libdpc ISA paths this CPU supports, read from /proc/cpuinfo (shared by the tests)."""

from pathlib import Path


def cpu_flags() -> set[str]:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("flags"):
                return set(line.split(":", 1)[1].split())
    except OSError:
        pass
    return set()


HAVE_AVX2 = {"avx2", "fma"} <= cpu_flags()
HAVE_AVX512 = HAVE_AVX2 and "avx512f" in cpu_flags()
VECTOR_ISAS = (["avx2"] if HAVE_AVX2 else []) + (["avx512"] if HAVE_AVX512 else [])
