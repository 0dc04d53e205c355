"""A Zenoh router for the tests, standing in for `zenohd`: it loads the `zenohd.json5` that
`fusion-server keys --routers ID` writes (router mode, TLS, the access-control list) and
runs until it is stopped. Usage: python zenoh_router.py PATH/zenohd.json5
"""

import signal
import sys
import threading

import zenoh


def main() -> int:
    config = zenoh.Config.from_file(sys.argv[1])
    stop = threading.Event()
    signal.signal(signal.SIGTERM, lambda *_: stop.set())
    signal.signal(signal.SIGINT, lambda *_: stop.set())
    session = zenoh.open(config)
    print(f"router up on {config.get_json('listen/endpoints')}", flush=True)
    stop.wait()
    session.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
