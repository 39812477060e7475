"""Apply dpc's pbrt-v4 integration to a pbrt-v4 source tree (it edits that tree in place).

    python3 integrations/pbrt-v4/apply.py PBRT_SRC          # apply (again: a no-op)
    python3 integrations/pbrt-v4/apply.py PBRT_SRC --check  # exit 0 if applied, 1 if not

It copies this folder's src/ (our DPCSampler and the mapping it forwards to) to PBRT_SRC/src/pbrt/dpc/,
and inserts our lines into six of pbrt's files at anchors it finds there: the CMake option
PBRT_DPC (find_package(dpc CONFIG), dpc::dpc linked into pbrt_lib), DPCSampler in the Sampler
type list and in Sampler::Create as "dpc", and dpc in pbrt's sampler and integrator tests. Every
insertion is guarded by PBRT_HAS_DPC (defined only with -DPBRT_DPC=ON) and carries a marker
comment "dpc-pbrt: NAME"; an insertion whose marker is there already is skipped, so applying
twice changes nothing. A missing anchor stops the script before any file is written, naming the
file and the text it looked for. Without a .git in PBRT_SRC (an archive, not a clone), pbrt's
submodule check cannot run: the inserted lines skip it then (a missing OpenEXR or zlib submodule is
then served by the system's package, as pbrt's CMakeLists.txt looks for those first).
"""

from __future__ import annotations

import argparse
import filecmp
import shutil
import sys
from dataclasses import dataclass
from pathlib import Path

HERE = Path(__file__).resolve().parent
MARK = "dpc-pbrt"


@dataclass(frozen=True)
class Edit:
    path: str  # relative to PBRT_SRC
    name: str  # the marker "dpc-pbrt: NAME" that the inserted text holds
    anchor: str  # text that must occur exactly once
    text: str  # inserted before or after the anchor
    before: bool = False


def cmake(name: str, body: str, indent: str = "") -> str:
    return f"{indent}# {MARK}: {name}\n{body}"


def cpp(name: str, body: str) -> str:
    return f"// {MARK}: {name}\n{body}"


EDITS = [
    Edit(
        "CMakeLists.txt",
        "no-git-check",
        "function (CHECK_EXT NAME DIR HASH)\n",
        cmake(
            "no-git-check",
            "  # A tree without .git (an archive) cannot show its submodules' commits; pbrt finds\n"
            "  # OpenEXR and zlib as system packages when their submodules are absent.\n"
            '  if (NOT EXISTS "${CMAKE_CURRENT_SOURCE_DIR}/.git")\n'
            '    if (IS_DIRECTORY "${CMAKE_CURRENT_SOURCE_DIR}/src/ext/${DIR}")\n'
            '      message (STATUS "${NAME}: no .git in the source tree, submodule commit not checked")\n'
            "    else ()\n"
            '      message (STATUS "${NAME}: no submodule (no .git, not checked): a system package must serve")\n'
            "    endif ()\n"
            "    return ()\n"
            "  endif ()\n",
            indent="  ",
        ),
    ),
    Edit(
        "CMakeLists.txt",
        "option",
        "set (PBRT_SOURCE\n",
        cmake(
            "option",
            'option (PBRT_DPC "Sampler \\"dpc\\": libdpc\'s blue-noise sampler, CPU only '
            '(find_package(dpc CONFIG): set dpc_DIR or CMAKE_PREFIX_PATH)" OFF)\n'
            "if (PBRT_DPC)\n"
            "  if (PBRT_CUDA_ENABLED)\n"
            '    message (FATAL_ERROR "PBRT_DPC: the dpc sampler is CPU-only; configure pbrt without the GPU build")\n'
            "  endif ()\n"
            "  find_package (dpc CONFIG REQUIRED)\n"
            '  message (STATUS "dpc ${DPC_VERSION}: Sampler \\"dpc\\" enabled, models in ${DPC_MODEL_DIR}")\n'
            '  list (APPEND PBRT_DEFINITIONS "PBRT_HAS_DPC")\n'
            "endif ()\n\n",
        ),
        before=True,
    ),
    Edit(
        "CMakeLists.txt",
        "sources",
        "add_library (pbrt_lib STATIC\n",
        cmake(
            "sources",
            "if (PBRT_DPC)\n"
            "  list (APPEND PBRT_SOURCE src/pbrt/dpc/dpc_pbrt_map.cpp src/pbrt/dpc/dpc_sampler_pbrt.cpp)\n"
            "endif ()\n",
        ),
        before=True,
    ),
    Edit(
        "CMakeLists.txt",
        "link",
        "  OpenGL::GL)\n",
        cmake(
            "link (PUBLIC: pbrt, imgtool and pbrt_test include dpc.h through samplers.h)",
            "if (PBRT_DPC)\n  target_link_libraries (pbrt_lib PUBLIC dpc::dpc)\nendif ()\n",
        ),
    ),
    Edit(
        "src/pbrt/base/sampler.h",
        "declaration",
        "class DebugMLTSampler;\n",
        cpp("declaration", "class DPCSampler;\n"),
    ),
    Edit(
        "src/pbrt/base/sampler.h",
        "type-list",
        "ZSobolSampler, MLTSampler, DebugMLTSampler\n",
        cpp("type-list", "#ifdef PBRT_HAS_DPC\n          , DPCSampler\n#endif\n"),
    ),
    Edit(
        "src/pbrt/samplers.h",
        "include",
        "#include <string>\n\nnamespace pbrt {\n",
        cpp("include", "#ifdef PBRT_HAS_DPC\n#include <pbrt/dpc/dpc_sampler_pbrt.h>\n#endif\n\n"),
        before=True,
    ),
    Edit(
        "src/pbrt/samplers.cpp",
        "create",
        '    else if (name == "stratified")\n        sampler = StratifiedSampler::Create(parameters, loc, alloc);\n',
        cpp(
            "create",
            "#ifdef PBRT_HAS_DPC\n"
            '    else if (name == "dpc")\n'
            "        sampler = DPCSampler::Create(parameters, loc, alloc);\n"
            "#else\n"
            '    else if (name == "dpc")\n'
            '        ErrorExit(loc, "dpc: this pbrt was built without the dpc sampler (cmake -DPBRT_DPC=ON)");\n'
            "#endif\n",
        ),
    ),
    Edit(
        "src/pbrt/samplers_test.cpp",
        "consistent-values",
        "    samplers.push_back(new SobolSampler(spp, resolution, RandomizeStrategy::FastOwen));\n",
        cpp(
            "consistent-values",
            "#ifdef PBRT_HAS_DPC\n"
            "    samplers.push_back(new DPCSampler(spp));\n"
            '    samplers.push_back(new DPCSampler(spp, "bnot-2d-stratified,bnot-2d", 5));\n'
            "#endif\n",
        ),
    ),
    Edit(
        "src/pbrt/samplers_test.cpp",
        "elementary-intervals",
        "TEST(ZSobolSampler, ValidIndices) {\n",
        cpp(
            "elementary-intervals",
            "#ifdef PBRT_HAS_DPC\n"
            "// The dpc sampler's film position (GetPixel2D: its slot 0) is a (0,m,2)-net in every pixel\n"
            '// when spp = 2^m (dpc_sampler.h, "Net slots"), whatever the seed.\n'
            "TEST(DPCSampler, ElementaryIntervals) {\n"
            "    for (int seed : {0, 1, 7})\n"
            "        for (int logSamples = 1; logSamples <= 10; ++logSamples)\n"
            "            checkElementarySampler(\n"
            '                StringPrintf("DPCSampler - seed %d", seed).c_str(),\n'
            '                new DPCSampler(1 << logSamples, "bnot-2d-stratified", seed), logSamples, 4);\n'
            "}\n"
            "#endif\n\n",
        ),
        before=True,
    ),
    Edit(
        "src/pbrt/cpu/integrators_test.cpp",
        "analytic-scenes",
        '    samplers.push_back(std::make_pair(new PMJ02BNSampler(spp), "PMJ02bn"));\n',
        cpp(
            "analytic-scenes",
            '#ifdef PBRT_HAS_DPC\n    samplers.push_back(std::make_pair(new DPCSampler(spp), "dpc"));\n#endif\n',
        ),
    ),
]


def fail(message: str) -> None:
    print(f"apply.py: {message}", file=sys.stderr)
    sys.exit(2)


def patched(source: str, edits: list[Edit], path: str) -> tuple[str, list[str]]:
    """The file's text with the edits not yet there inserted, and the names inserted."""
    done = []
    for e in edits:
        if f"{MARK}: {e.name}" in source:
            continue
        count = source.count(e.anchor)
        if count != 1:
            what = "not found" if count == 0 else f"found {count} times"
            fail(
                f"{path}: anchor for '{e.name}' {what}: {e.anchor!r}. Is this pbrt-v4 "
                "(the integration was written against commit 5f7a6068)? Nothing was written."
            )
        at = source.index(e.anchor) + (0 if e.before else len(e.anchor))
        source = source[:at] + e.text + source[at:]
        done.append(e.name)
    return source, done


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n", maxsplit=1)[0])
    parser.add_argument("pbrt_src", type=Path, help="a pbrt-v4 source tree (the folder with its CMakeLists.txt)")
    parser.add_argument("--check", action="store_true", help="only report: exit 0 if applied, 1 if not")
    args = parser.parse_args()
    root = args.pbrt_src.resolve()
    if not (root / "src/pbrt/samplers.cpp").is_file():
        fail(f"{root} has no src/pbrt/samplers.cpp: give the pbrt-v4 source tree")

    # every file's new text first, so that a missing anchor leaves the tree as it was
    writes: dict[Path, str] = {}
    report = []
    for path in dict.fromkeys(e.path for e in EDITS):
        file = root / path
        if not file.is_file():
            fail(f"{file} is missing. Nothing was written.")
        text, done = patched(file.read_text(), [e for e in EDITS if e.path == path], path)
        if done:
            writes[file] = text
            report.append(f"{path}: inserted {', '.join(done)}")
    target = root / "src/pbrt/dpc"
    copies = []
    for source in sorted((HERE / "src").iterdir()):
        if source.suffix in (".h", ".cpp"):
            dest = target / source.name
            if not dest.is_file() or not filecmp.cmp(source, dest, shallow=False):
                copies.append((source, dest))
                report.append(f"src/pbrt/dpc/{source.name}: {'updated' if dest.exists() else 'copied'}")

    if args.check:
        print("\n".join(report) if report else f"{root}: the dpc integration is applied")
        return 1 if report else 0
    for file, text in writes.items():
        file.write_text(text)
    target.mkdir(exist_ok=True)
    for source, dest in copies:
        shutil.copyfile(source, dest)
    print("\n".join(report) if report else f"{root}: already applied, nothing changed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
