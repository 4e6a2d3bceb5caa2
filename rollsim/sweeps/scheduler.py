"""Reaching a user's Dask scheduler: the address checked, a deadline kept, and what answered said.

Dask's client waits for a scheduler's greeting with no deadline of its own,
so an address where something else listens (a web server, a socket that
accepts and never speaks) would hold a command for as long as one waits.
Before any Dask client is made, :func:`probe_scheduler` opens the connection
itself, with a deadline, and reads the first bytes: a Dask scheduler greets
every connection at once (its handshake), anything else is named in one line.

The deadline is ``--connect-timeout SECONDS``, else
``$ROLLSIM_CONNECT_TIMEOUT``, else :data:`DEFAULT_CONNECT_TIMEOUT_S`.
"""

from __future__ import annotations

import math
import os
import socket
import time
from dataclasses import dataclass
from typing import Optional

from rollsim.errors import RollsimError, SystemFailure, clip

DEFAULT_CONNECT_TIMEOUT_S = 10.0
MAX_CONNECT_TIMEOUT_S = 3600.0
ENV_VAR = "ROLLSIM_CONNECT_TIMEOUT"
DEFAULT_PORT = 8786
# Schemes whose first bytes are Dask's own (tls and ws wrap them in
# another protocol's handshake, which only Dask's client speaks).
_PLAIN_SCHEMES = ("tcp",)
_SCHEMES = ("tcp", "tls", "ws", "wss")
# A web server answers this at once, and names itself in its status line.
_HTTP_QUESTION = b"HEAD / HTTP/1.0\r\n\r\n"


@dataclass(frozen=True)
class SchedulerAddress:
    """A scheduler's address, split: ``scheme://host:port``."""

    scheme: str
    host: str
    port: int

    @property
    def url(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"{self.scheme}://{host}:{self.port}"


def connect_timeout_s(value: Optional[float] = None) -> float:
    """The connection deadline in seconds: ``value``, else ``$ROLLSIM_CONNECT_TIMEOUT``, else 10 s.

    Raises
    ------
    RollsimError
        Not a finite number in (0, 3600], naming the option or variable.
    """
    source = "--connect-timeout"
    if value is None:
        text = os.environ.get(ENV_VAR)
        if text is None:
            return DEFAULT_CONNECT_TIMEOUT_S
        source = f"${ENV_VAR}"
        try:
            value = float(text[:40])
        except ValueError:
            raise RollsimError(f"{source} = {clip(text, 40)!r}: expected a number of seconds") from None
    if not (math.isfinite(value) and 0 < value <= MAX_CONNECT_TIMEOUT_S):
        raise RollsimError(f"{source} = {value}: must be a number of seconds in (0, {MAX_CONNECT_TIMEOUT_S:g}]")
    return float(value)


def parse_scheduler_address(address: str) -> SchedulerAddress:
    """Split ``tcp://HOST:PORT`` (or ``HOST:PORT``, ``tls://``, ``ws://``, ``wss://``).

    Raises
    ------
    RollsimError
        One line naming the address and the form expected; an ``http://``
        address is told apart (it is the dashboard's, not the scheduler's).
    """
    shown = clip(str(address), 120)
    text = str(address).strip()
    scheme, sep, rest = text.partition("://")
    if not sep:
        scheme, rest = "tcp", text
    scheme = scheme.lower()
    if scheme in ("http", "https"):
        raise RollsimError(f"--scheduler {shown}: an {scheme}:// address is a web page's (Dask's dashboard is "
                           f"http://HOST:8787); a scheduler's is tcp://HOST:PORT (port {DEFAULT_PORT} by default)")
    if scheme not in _SCHEMES:
        raise RollsimError(f"--scheduler {shown}: unknown scheme {clip(scheme, 20)!r}; expected tcp://HOST:PORT "
                           f"({', '.join(s + '://' for s in _SCHEMES)})")
    host, port = _split_host_port(rest.rstrip("/"), shown)
    return SchedulerAddress(scheme, host, port)


def _split_host_port(text: str, shown: str) -> tuple[str, int]:
    if text.startswith("["):  # [IPv6]:PORT
        host, _, tail = text[1:].partition("]")
        port_text = tail[1:] if tail.startswith(":") else None
    elif ":" in text:
        host, _, port_text = text.rpartition(":")
    else:
        host, port_text = text, None
    bad = f"--scheduler {shown}: expected tcp://HOST:PORT"
    if not host or any(c.isspace() or c in "/?#@[]" for c in host):
        raise RollsimError(f"{bad} (no host name)")
    if port_text is None:
        return host, DEFAULT_PORT
    if not (port_text.isdigit() and len(port_text) <= 5 and 0 < int(port_text) < 65536):
        raise RollsimError(f"{bad} (port {clip(port_text, 20)!r} is not a number from 1 to 65535)")
    return host, int(port_text)


def probe_scheduler(address: SchedulerAddress, timeout_s: float) -> None:
    """Connect to ``address`` and wait for a Dask scheduler's greeting, within ``timeout_s`` seconds.

    For ``tcp://`` the first bytes are read; for the wrapped schemes only
    the connection is made (their greeting is another protocol's).

    Raises
    ------
    SystemFailure
        One line: the address and what answered (nothing listening, no
        answer, a closed connection, a web server, other text).
    """
    deadline = time.monotonic() + timeout_s
    prefix = f"--scheduler {address.url}"
    try:
        connection = socket.create_connection((address.host, address.port), timeout=timeout_s)
    except socket.gaierror as exc:
        raise SystemFailure(f"{prefix}: unknown host {address.host!r} ({exc.strerror})") from None
    except ConnectionRefusedError:
        raise SystemFailure(f"{prefix}: nothing listens there (connection refused)") from None
    except (socket.timeout, TimeoutError):
        raise SystemFailure(f"{prefix}: no answer to the connection within {timeout_s:g} s "
                            f"(--connect-timeout)") from None
    except OSError as exc:
        raise SystemFailure(f"{prefix}: cannot connect ({exc.strerror or type(exc).__name__})") from None
    with connection:
        if address.scheme in _PLAIN_SCHEMES:
            problem = _greeting_problem(connection, deadline, timeout_s)
            if problem is not None:
                raise SystemFailure(f"{prefix}: {problem}: not a Dask scheduler (a scheduler greets every "
                                    f"connection at once; its port is {DEFAULT_PORT} by default)")


def _greeting_problem(connection: socket.socket, deadline: float, timeout_s: float) -> Optional[str]:
    """What is wrong with the peer's first bytes, or None for a Dask greeting."""
    # Most of the time goes to waiting for the greeting; the last quarter
    # (at most 2 s) asks a silent peer whether it is a web server.
    ask_s = min(2.0, timeout_s / 4)
    first = _receive(connection, deadline - ask_s)
    if first is None:
        if _send(connection, _HTTP_QUESTION):
            answer = _receive(connection, deadline)
            if answer and answer.startswith(b"HTTP/"):
                return f"a web server answered ({_text_of(answer)})"
        return f"it accepted the connection but said nothing within {timeout_s:g} s (--connect-timeout)"
    if not first:
        return "it accepted the connection and closed it without a word"
    if _looks_like_text(first):
        return f"it answered {_text_of(first)!r}"
    return None


def _receive(connection: socket.socket, until: float) -> Optional[bytes]:
    """Up to 256 bytes from ``connection`` before monotonic time ``until``; None if none came."""
    left = until - time.monotonic()
    if left <= 0:
        return None
    connection.settimeout(left)
    try:
        return connection.recv(256)
    except (socket.timeout, TimeoutError):
        return None
    except OSError:  # reset by the peer: as good as closed
        return b""


def _send(connection: socket.socket, data: bytes) -> bool:
    try:
        connection.sendall(data)
    except OSError:
        return False
    return True


def _looks_like_text(data: bytes) -> bool:
    """True for bytes that read as a line of text (a banner, a status line); Dask's greeting is binary."""
    head = data[:64]
    return all(32 <= b < 127 or b in (9, 10, 13) for b in head)


def _text_of(data: bytes) -> str:
    """The first line of ``data`` as text, clipped."""
    line = data.split(b"\n", 1)[0].decode("ascii", "replace").strip()
    return clip(line, 60)
