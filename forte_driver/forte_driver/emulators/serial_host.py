"""A minimal sensor host for the bench-device tests: pyserial and the protocol decoder."""
from __future__ import annotations

import time

import serial

from forte_driver.serial import protocol
from forte_driver.serial.protocol import Ack, Command, FrameDecoder, Info, Sample


class Host:
    """A minimal host: pyserial port + decoder, collecting everything it receives."""

    def __init__(self, path: str) -> None:
        self.port = serial.Serial(path, timeout=0.02)
        self.decoder = FrameDecoder()
        self.samples: list[Sample] = []
        self.acks: list[Ack] = []
        self.infos: list[Info] = []
        self.token = 0

    def send(self, command: Command, argument: int = 0) -> int:
        self.token += 1
        self.port.write(protocol.encode_command(command, self.token, argument))
        return self.token

    def pump(self, seconds: float, until=None) -> None:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            for item in self.decoder.feed(self.port.read(max(1, self.port.in_waiting))):
                if isinstance(item, Sample):
                    self.samples.append(item)
                elif isinstance(item, Ack):
                    self.acks.append(item)
                elif isinstance(item, Info):
                    self.infos.append(item)
            if until is not None and until():
                return

    def command(self, command: Command, argument: int = 0) -> Ack:
        token = self.send(command, argument)
        self.pump(5.0, until=lambda: any(a.token == token for a in self.acks))
        return next(a for a in self.acks if a.token == token)

    def close(self) -> None:
        self.port.close()
