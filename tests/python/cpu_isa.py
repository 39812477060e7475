"""Which libdpc ISA paths this build and CPU run (dpc.isa_supported; shared by the tests)."""

import dpc

HAVE_AVX2 = dpc.isa_supported("avx2")
HAVE_AVX512 = dpc.isa_supported("avx512")
VECTOR_ISAS = (["avx2"] if HAVE_AVX2 else []) + (["avx512"] if HAVE_AVX512 else [])
