"""Running processes: short commands whose output is wanted (capture), and
measured runs (measure_process): wall time, the process's own peak memory
and its memory per stage of the mapper's log."""

import os
import re
import shlex
import signal
import subprocess
import threading
import time

from glomap_bench import parse

DEFAULT_SAMPLE_INTERVAL_S = 0.2

# Set by Ctrl-C (SIGINT) or SIGTERM once a benchmark has installed
# request_stop(): the process being measured is killed and recorded as
# interrupted, and no further run starts. A flag instead of
# KeyboardInterrupt, so that the signal cannot land in the middle of the
# bookkeeping.
STOP = threading.Event()


def log(message):
    print(message, flush=True)


def capture(command):
    """Runs a short command; returns (exit code, stdout+stderr)."""
    result = subprocess.run(command, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    return result.returncode, result.stdout


def last_lines(path, count=3):
    """The last `count` non-empty lines of a file, right-stripped."""
    with open(path, errors="replace") as f:
        lines = [line.rstrip() for line in f if line.strip()]
    return lines[-count:]


def read_proc_memory(pid):
    """(VmRSS, VmHWM) of a live process in MB; (None, None) once it has
    exited (a zombie has no memory lines) or without /proc."""
    try:
        with open("/proc/%d/status" % pid) as f:
            text = f.read()
    except OSError:
        return None, None
    rss = re.search(r"^VmRSS:\s*(\d+)\s*kB", text, re.M)
    hwm = re.search(r"^VmHWM:\s*(\d+)\s*kB", text, re.M)
    if not rss:
        return None, None
    return (int(rss.group(1)) / 1024.0,
            int(hwm.group(1)) / 1024.0 if hwm else None)


def stage_memory(samples):
    """Peak memory per stage from samples [(stage or None, stage line read
    since the previous sample, VmRSS MB, VmHWM MB)], in order: the largest
    VmRSS sampled in the stage, and the high-water mark after a rise between
    two samples of the same stage without a stage line in between (then the
    peak was reached inside the stage). None stands for parse.OTHER. Returns
    ({stage: peak MB}, {stage: sample count})."""
    peaks, counts = {}, {}
    previous = None
    for stage, changed, rss, hwm in samples:
        name = stage or parse.OTHER
        counts[name] = counts.get(name, 0) + 1
        peak = peaks.get(name, 0.0)
        if rss is not None:
            peak = max(peak, rss)
        if (previous is not None and not changed and previous[0] == stage
                and hwm is not None and previous[3] is not None
                and hwm > previous[3]):
            peak = max(peak, hwm)
        peaks[name] = peak
        previous = (stage, changed, rss, hwm)
    return peaks, counts


def signal_name(number):
    """"SIGKILL" for 9; "signal <n>" for a number without a name."""
    try:
        return signal.Signals(number).name
    except ValueError:
        return "signal %d" % number


def request_stop(signum, frame):
    """Signal handler: sets STOP (see there)."""
    if not STOP.is_set():
        log("\n%s: stopping after the run in progress is recorded" %
            signal_name(signum))
    STOP.set()


def measure_process(command, log_path, timeout_s=None,
                    interval_s=DEFAULT_SAMPLE_INTERVAL_S):
    """Runs command with stdout+stderr to log_path (its first line "$ " and
    the command), sampling its memory. timeout_s: None or 0 for never.
    Returns {"exit_code" (None if killed by a signal), "signal" (name or
    None), "signal_number" (or None), "wall_s", "peak_rss_mb" (the process's
    own ru_maxrss from os.wait4), "timed_out", "interrupted" (Ctrl-C or
    STOP: the process was killed), "stage_peak_rss_mb",
    "stage_rss_samples"}; peak_rss_mb is at least every sample (see below).
    A thread waits for the process (os.wait4), so that its end time is exact
    and not rounded up to the next sample."""
    with open(log_path, "w") as log_file:
        log_file.write("$ " + shlex.join(command) + "\n")
        log_file.flush()
        start = time.monotonic()
        process = subprocess.Popen(command, stdout=log_file,
                                   stderr=subprocess.STDOUT)
    ended = {}
    done = threading.Event()

    def wait_for_process():
        _, status, usage = os.wait4(process.pid, 0)
        ended.update(time=time.monotonic(), status=status, usage=usage)
        done.set()

    waiter = threading.Thread(target=wait_for_process, daemon=True)
    waiter.start()
    tracker = parse.StageTracker(log_path)
    samples = []
    timed_out = interrupted = False

    def kill():
        if not done.is_set():
            try:
                os.kill(process.pid, signal.SIGKILL)
            except OSError:
                pass

    try:
        while not done.is_set():
            if STOP.is_set():
                interrupted = True
                kill()
                break
            stage, changed = tracker.poll()
            rss, hwm = read_proc_memory(process.pid)
            if rss is not None and not done.is_set():
                samples.append((stage, changed, rss, hwm))
            elif changed and samples:
                # The stage line still separates the samples around it.
                samples[-1] = samples[-1][:1] + (True,) + samples[-1][2:]
            if timeout_s and time.monotonic() - start > timeout_s:
                timed_out = True
                kill()
                break
            done.wait(interval_s)
    except KeyboardInterrupt:
        interrupted = True
        kill()
    waiter.join()
    # Ctrl-C reaches the process too, which may end before the loop sees
    # the request.
    interrupted = interrupted or STOP.is_set()
    status = ended["status"]
    # Reaped by the thread: keep Popen from waiting for the pid again.
    process.returncode = os.waitstatus_to_exitcode(status)
    peaks, counts = stage_memory(samples)
    exit_code = signal_number = None
    if os.WIFEXITED(status):
        exit_code = os.WEXITSTATUS(status)
    elif os.WIFSIGNALED(status):
        signal_number = os.WTERMSIG(status)
    # Linux reports ru_maxrss in kB. The kernel's RSS counters are
    # synchronised lazily, so a sample can exceed it by a few hundred kB:
    # the peak is the larger of both.
    peak_mb = max([ended["usage"].ru_maxrss / 1024.0] +
                  [v for sample in samples for v in sample[2:]
                   if v is not None])
    return {"exit_code": exit_code,
            "signal": signal_name(signal_number) if signal_number else None,
            "signal_number": signal_number,
            "wall_s": ended["time"] - start,
            "peak_rss_mb": peak_mb,
            "timed_out": timed_out, "interrupted": interrupted,
            "stage_peak_rss_mb": peaks, "stage_rss_samples": counts}


def shell_exit_code(measured):
    """The exit code of a measure_process() result as a shell reports it:
    128 + the signal's number for a process killed by a signal."""
    if measured["exit_code"] is not None:
        return measured["exit_code"]
    return 128 + (measured["signal_number"] or 0)


def process_status(measured, timeout_s):
    """"ok" or why a process did not finish normally."""
    if measured["interrupted"]:
        return "interrupted"
    if measured["timed_out"]:
        return "timeout after %d s" % timeout_s
    if measured["signal"]:
        return "killed by %s%s" % (measured["signal"],
                                   " (out of memory?)"
                                   if measured["signal"] == "SIGKILL" else "")
    if measured["exit_code"] != 0:
        return "failed: exit %d" % measured["exit_code"]
    return "ok"
