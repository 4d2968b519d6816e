"""meshcat's server bound to 127.0.0.1 only (its web server otherwise listens on every interface).

Run as a script by :mod:`vibdyn.faces.viewer.live` (``python -u _server.py``); it does not import vibdyn.
"""

import tornado.web

_listen = tornado.web.Application.listen


def _listen_local(self, port, address="127.0.0.1", **kwargs):
    return _listen(self, port, address="127.0.0.1", **kwargs)


tornado.web.Application.listen = _listen_local  # type: ignore[method-assign]  # the point of this script

if __name__ == "__main__":
    from meshcat.servers.zmqserver import main

    main()
