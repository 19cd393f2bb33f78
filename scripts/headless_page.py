#!/usr/bin/env python3
"""Opens a page in headless Chromium and waits (in real time) until it reports.

  scripts/headless_page.py URL STATUS_OUT [--screenshot PNG] [--timeout S] -- CHROMIUM [FLAGS...]

Polls the text of the page's `#status` element through the DevTools protocol (over
--remote-debugging-pipe, no extra package) until it is no longer "loading", writes it to
STATUS_OUT and, with --screenshot, a PNG of the page. Exit 0 when the page reported, 1 on
timeout. (Chromium's --virtual-time-budget with --dump-dom did not wait for the page: virtual
time runs ahead while WebGL and module loading wait in real time, and most runs on a loaded
machine dumped "loading".)
"""
import argparse
import base64
import json
import os
import subprocess
import sys
import time


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("url")
    ap.add_argument("status_out")
    ap.add_argument("--screenshot")
    ap.add_argument("--timeout", type=float, default=180)
    ap.add_argument("chromium", nargs="+", help="the Chromium command and its flags (after --)")
    args = ap.parse_args()

    # Chromium reads commands from fd 3 and writes answers to fd 4, each a JSON text and a NUL.
    to_chrome_r, to_chrome_w = os.pipe()
    from_chrome_r, from_chrome_w = os.pipe()

    def child_fds():
        os.dup2(to_chrome_r, 3)
        os.dup2(from_chrome_w, 4)
        os.set_inheritable(3, True)
        os.set_inheritable(4, True)

    chrome = subprocess.Popen(args.chromium + ["--headless", "--remote-debugging-pipe", "about:blank"],
                              preexec_fn=child_fds, close_fds=False, stdin=subprocess.DEVNULL,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    os.close(to_chrome_r)
    os.close(from_chrome_w)
    send = os.fdopen(to_chrome_w, "wb", buffering=0)
    receive = os.fdopen(from_chrome_r, "rb", buffering=0)
    pending = b""
    ident = 0

    def call(method, params=None, session=None):
        nonlocal ident, pending
        ident += 1
        message = {"id": ident, "method": method, "params": params or {}}
        if session:
            message["sessionId"] = session
        send.write(json.dumps(message).encode() + b"\0")
        while True:
            while b"\0" not in pending:
                chunk = receive.read(1 << 16)
                if not chunk:
                    raise RuntimeError("Chromium closed the DevTools pipe")
                pending += chunk
            raw, pending = pending.split(b"\0", 1)
            answer = json.loads(raw)
            if answer.get("id") == ident:  # events and other answers are skipped
                if "error" in answer:
                    raise RuntimeError("%s: %s" % (method, answer["error"]))
                return answer["result"]

    text = "loading"
    try:
        target = call("Target.createTarget", {"url": args.url})["targetId"]
        session = call("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
        deadline = time.monotonic() + args.timeout
        while time.monotonic() < deadline:
            result = call("Runtime.evaluate", {"expression": "(document.getElementById('status') || {}).textContent",
                                               "returnByValue": True}, session)["result"]
            text = result.get("value") or "loading"
            if text != "loading":
                break
            time.sleep(0.2)
        if text != "loading" and args.screenshot:
            png = call("Page.captureScreenshot", {"format": "png"}, session)["data"]
            with open(args.screenshot, "wb") as f:
                f.write(base64.b64decode(png))
        call("Browser.close")
    except RuntimeError as e:
        print("headless_page: %s" % e, file=sys.stderr)
    finally:
        try:
            chrome.wait(timeout=30)
        except subprocess.TimeoutExpired:
            chrome.kill()
    with open(args.status_out, "w") as f:
        f.write(text)
    if text == "loading":
        print("headless_page: the page did not report within %g s" % args.timeout, file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
