#!/usr/bin/env python3
"""Open a page in headless chromium and wait until it writes <pre id="probe">.

The report's browser test (report_test.cc) uses it. It speaks the DevTools protocol over
--remote-debugging-pipe (fd 3 into chromium, fd 4 out of it, messages ended by NUL), so it waits
for the probe itself, on the wall clock, instead of guessing when the page is done: chromium's
--virtual-time-budget deems a page idle while an image decodes off its main thread and could dump
the DOM before the probe was written.

Prints one JSON object: {"probe": the element's text or null, "exceptions": [...],
"console": [...] (console errors, and error log entries such as CSP refusals)}.
Exit status 0 when the probe was found, 1 when it was not within --timeout seconds.
Standard library only.
"""
import argparse
import fcntl
import json
import os
import subprocess
import sys
import time

PROBE = "(() => { const e = document.getElementById('probe'); return e ? e.textContent : null; })()"


class Pipe:
    def __init__(self, to_browser, from_browser):
        self.to_browser = to_browser
        self.from_browser = from_browser
        self.buffer = b""
        self.next_id = 0
        self.events = []

    def _read_message(self, deadline):
        while b"\0" not in self.buffer:
            if time.monotonic() > deadline:
                raise TimeoutError("chromium did not answer")
            chunk = os.read(self.from_browser, 1 << 16)
            if not chunk:
                raise EOFError("chromium closed its pipe")
            self.buffer += chunk
        message, self.buffer = self.buffer.split(b"\0", 1)
        return json.loads(message)

    def call(self, method, params=None, session=None, deadline=None):
        self.next_id += 1
        command = {"id": self.next_id, "method": method, "params": params or {}}
        if session:
            command["sessionId"] = session
        os.write(self.to_browser, json.dumps(command).encode() + b"\0")
        deadline = deadline or time.monotonic() + 30.0
        while True:
            message = self._read_message(deadline)
            if message.get("id") == self.next_id:
                if "error" in message:
                    raise RuntimeError(f"{method}: {message['error']}")
                return message.get("result", {})
            self.events.append(message)


def describe(event):
    method, params = event.get("method"), event.get("params", {})
    if method == "Runtime.exceptionThrown":
        details = params.get("exceptionDetails", {})
        text = details.get("exception", {}).get("description") or details.get("text", "")
        return "exception", text
    if method == "Runtime.consoleAPICalled" and params.get("type") in ("error", "assert"):
        args = " ".join(str(a.get("value", a.get("description", "")))
                        for a in params.get("args", []))
        return "console", f"console.{params['type']}: {args}"
    if method == "Log.entryAdded":
        entry = params.get("entry", {})
        if entry.get("level") == "error":
            return "console", f"{entry.get('source')} {entry.get('level')}: {entry.get('text')}"
    return None, None


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("url")
    parser.add_argument("--user-data-dir", required=True)
    parser.add_argument("--window-size", default="1400,1800")
    parser.add_argument("--timeout", type=float, default=90.0, help="seconds of wall clock")
    args = parser.parse_args()

    into_r, into_w = os.pipe()  # we write, chromium reads on fd 3
    out_r, out_w = os.pipe()  # chromium writes on fd 4, we read
    # the child's ends above fd 4, so that moving them to 3 and 4 never lands one on itself
    child_r = fcntl.fcntl(into_r, fcntl.F_DUPFD_CLOEXEC, 10)
    child_w = fcntl.fcntl(out_w, fcntl.F_DUPFD_CLOEXEC, 10)
    for fd in (into_r, out_w):
        os.close(fd)

    def wire():  # in the child: dup2 leaves 3 and 4 open across exec
        os.dup2(child_r, 3)
        os.dup2(child_w, 4)

    log_path = os.path.join(args.user_data_dir, "chromium_stderr.log")
    log = open(log_path, "wb")  # a file, not a pipe: chromium must never block on it
    browser = subprocess.Popen(
        ["chromium", "--headless=new", "--no-sandbox", "--disable-gpu", "--no-first-run",
         "--user-data-dir=" + args.user_data_dir, "--window-size=" + args.window_size,
         "--remote-debugging-pipe", "about:blank"],
        stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=log,
        preexec_fn=wire, close_fds=False)
    log.close()
    os.close(child_r)
    os.close(child_w)
    pipe = Pipe(into_w, out_r)
    result = {"probe": None, "exceptions": [], "console": []}
    found = False
    try:
        target = pipe.call("Target.createTarget", {"url": "about:blank"})["targetId"]
        attached = pipe.call("Target.attachToTarget", {"targetId": target, "flatten": True})
        session = attached["sessionId"]
        for domain in ("Runtime.enable", "Log.enable", "Page.enable"):
            pipe.call(domain, session=session)
        navigated = pipe.call("Page.navigate", {"url": args.url}, session=session)
        if "errorText" in navigated:
            result["exceptions"].append(f"cannot open {args.url}: {navigated['errorText']}")
        deadline = time.monotonic() + args.timeout
        while not result["exceptions"] and time.monotonic() < deadline:
            value = pipe.call("Runtime.evaluate", {"expression": PROBE, "returnByValue": True},
                              session=session)["result"].get("value")
            if value is not None:
                result["probe"], found = value, True
                break
            # an uncaught exception most likely stopped the probe: a few seconds more, not all
            if any(describe(e)[0] == "exception" for e in pipe.events):
                deadline = min(deadline, time.monotonic() + 3.0)
            time.sleep(0.1)
        for event in pipe.events:
            kind, text = describe(event)
            if kind:
                result["exceptions" if kind == "exception" else "console"].append(text)
        try:
            pipe.call("Browser.close", deadline=time.monotonic() + 10.0)
        except (EOFError, TimeoutError):
            pass
    finally:
        try:
            browser.wait(timeout=10)
        except subprocess.TimeoutExpired:
            browser.kill()
            browser.wait()
    if not found:
        with open(log_path, "rb") as text:
            lines = text.read().decode(errors="replace").splitlines()
        # its complaints about the missing D-Bus of a headless machine say nothing about the page
        useful = [line for line in lines if "dbus" not in line.lower()]
        result["chromium_stderr"] = "\n".join(useful)[-4000:]
    json.dump(result, sys.stdout)
    print()
    return 0 if found else 1


if __name__ == "__main__":
    sys.exit(main())
