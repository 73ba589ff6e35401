"""Where a report's figures come from: the exact command and its folder, the
source commit, the build type and path of each binary, and the machine."""

import hashlib
import os
import platform
import re
import shlex
import subprocess

from glomap_bench import tables


def format_command(argv, cwd):
    """The exact command (sys.argv, shell-quoted) and the folder it ran in:
    `python3 <argv>` for a script path, argv itself otherwise."""
    words = list(argv)
    if words and words[0].endswith(".py"):
        words = ["python3"] + words
    return shlex.join(words), cwd


def git_commit(path):
    """`git rev-parse --short HEAD` of the tree at path, with "+dirty" when
    `git status --porcelain` lists changes to tracked files; None if it is
    not a git tree."""
    try:
        head = subprocess.run(["git", "-C", path, "rev-parse", "--short",
                               "HEAD"], stdout=subprocess.PIPE,
                              stderr=subprocess.DEVNULL, text=True)
        if head.returncode != 0 or not head.stdout.strip():
            return None
        status = subprocess.run(["git", "-C", path, "status", "--porcelain",
                                 "--untracked-files=no"],
                                stdout=subprocess.PIPE,
                                stderr=subprocess.DEVNULL, text=True)
    except OSError:
        return None
    dirty = status.returncode != 0 or bool(status.stdout.strip())
    return head.stdout.strip() + ("+dirty" if dirty else "")


def parse_cmake_cache(text):
    """(CMAKE_BUILD_TYPE or "unknown", CMAKE_HOME_DIRECTORY or None) of a
    CMakeCache.txt's text."""
    build = re.search(r"^CMAKE_BUILD_TYPE(?::\w+)?=(.*)$", text, re.M)
    home = re.search(r"^CMAKE_HOME_DIRECTORY(?::\w+)?=(.*)$", text, re.M)
    build = build.group(1).strip() if build else ""
    return build or "unknown", home.group(1).strip() if home else None


def binary_info(binary, source_dir=None):
    """Path, build type and source commit of a colmap binary: the build type
    from <build>/CMakeCache.txt for <build>/bin/<binary> ("unknown" without
    one); the commit of source_dir, else of the cache's source folder."""
    binary = os.path.abspath(binary)
    cache = os.path.join(os.path.dirname(os.path.dirname(binary)),
                         "CMakeCache.txt")
    build_type, home = "unknown", None
    try:
        with open(cache, errors="replace") as f:
            build_type, home = parse_cmake_cache(f.read())
    except OSError:
        pass
    source = source_dir or home
    return {"path": binary, "build_type": build_type, "source": source,
            "commit": git_commit(source) if source else None}


def file_sha256(path):
    """The hex sha256 of a file's content."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def machine_info():
    """CPU model, core count, total memory (GiB) and kernel."""
    info = {"cpu": platform.processor() or platform.machine(),
            "cores": os.cpu_count(), "memory_gib": None,
            "kernel": "%s %s" % (platform.system(), platform.release())}
    try:
        with open("/proc/cpuinfo") as f:
            match = re.search(r"model name\s*:\s*(.+)", f.read())
            if match:
                info["cpu"] = match.group(1).strip()
    except OSError:
        pass
    try:
        with open("/proc/meminfo") as f:
            match = re.search(r"MemTotal:\s*(\d+)\s*kB", f.read())
            if match:
                info["memory_gib"] = int(match.group(1)) / 1024.0 ** 2
    except OSError:
        pass
    return info


def provenance_lines(meta):
    """The three lines that head the reports: the command, the source and
    binaries (meta["colmap"], meta["reference_colmap"]: binary_info()), the
    machine (machine_info()) and the date."""
    lines = ["Command: `%s` (in `%s`)." % (meta["command"], meta["cwd"])]
    binaries = []
    for key, label in (("colmap", "ours"), ("reference_colmap",
                                            "reference")):
        info = meta.get(key)
        if not info:
            continue
        text = "%s `%s` (%s" % (label, info["path"], info["build_type"])
        if key != "colmap":
            text += ", source %s" % ("commit %s of `%s`" % (
                info["commit"], info["source"]) if info.get("commit")
                else "unknown")
        binaries.append(text + ")")
    ours = meta.get("colmap") or {}
    lines.append("Source: commit %s of `%s`; binaries: %s." % (
        ours.get("commit") or "unknown", ours.get("source") or "?",
        "; ".join(binaries)))
    machine = meta["machine"]
    lines.append("Machine: %s, %s cores, %s GiB memory, %s; %s." % (
        machine["cpu"], machine["cores"],
        tables.fmt(machine.get("memory_gib"), 1), machine["kernel"],
        meta["date"]))
    return lines
