"""Protocol 2.0 codec: CRC known answers (e-manual examples), byte stuffing, resync."""
import random

from dynamixel_sdk import PacketHandler

from forte_driver.dynamixel import protocol as proto


def test_crc_of_e_manual_ping_instruction():
    # e-manual example: ping id 1 = FF FF FD 00 01 03 00 01 19 4E
    assert proto.crc16(bytes.fromhex('fffffd0001030001')) == 0x4E19
    assert proto.build_packet(1, proto.INSTRUCTION_PING) == bytes.fromhex(
        'fffffd0001030001194e')


def test_status_packet_of_e_manual_ping_answer():
    # e-manual example: id 1 answers model 0x0406, firmware 0x26 -> ... 65 5D
    assert proto.build_status(1, 0, bytes([0x06, 0x04, 0x26])) == bytes.fromhex(
        'fffffd000107005500060426655d')


def test_crc_agrees_with_dynamixel_sdk_on_random_data():
    sdk = PacketHandler(2.0)
    generator = random.Random(4)
    for length in (0, 1, 7, 64, 300):
        data = bytes(generator.randrange(256) for _ in range(length))
        assert proto.crc16(data) == sdk.updateCRC(0, list(data), len(data))


def test_byte_stuffing_round_trip():
    body = bytes([0x03, 0x14, 0x00, 0xFF, 0xFF, 0xFD, 0xFF])
    stuffed = proto.stuff(body)
    assert stuffed == bytes([0x03, 0x14, 0x00, 0xFF, 0xFF, 0xFD, 0xFD, 0xFF])
    assert proto.unstuff(stuffed) == body
    assert proto.stuff(b'\xfd\xfd\xff') == b'\xfd\xfd\xff'  # no FF FF FD: untouched


def test_stuffed_packet_length_counts_the_extra_byte_and_parses_back():
    params = bytes([0x14, 0x00, 0xFF, 0xFF, 0xFD, 0xFF])
    packet = proto.build_packet(1, proto.INSTRUCTION_WRITE, params)
    assert packet[5] | packet[6] << 8 == 1 + len(params) + 1 + 2  # inst + params + FD + CRC
    parsed = list(proto.PacketParser().feed(packet))
    assert len(parsed) == 1
    assert parsed[0].instruction == proto.INSTRUCTION_WRITE and parsed[0].parameters == params


def test_sdk_reads_a_stuffed_status_packet():
    status = proto.build_status(3, 0, bytes([0xFF, 0xFF, 0xFD, 0x01]))
    packet = list(status)
    PacketHandler(2.0).removeStuffing(packet)
    length = packet[5] | packet[6] << 8
    assert packet[9: 9 + length - 4] == [0xFF, 0xFF, 0xFD, 0x01]


def test_parser_resynchronises_after_garbage_and_counts_crc_errors():
    good = proto.build_packet(2, proto.INSTRUCTION_READ, bytes([132, 0, 4, 0]))
    corrupt = bytearray(good)
    corrupt[9] ^= 0x01
    stream = b'\x00\xff\x13' + bytes(corrupt) + b'\xff\xff' + good + good[:5]
    parser = proto.PacketParser()
    packets = []
    for index in range(0, len(stream), 3):  # arbitrary split points
        packets.extend(parser.feed(stream[index: index + 3]))
    assert [(p.device_id, p.parameters) for p in packets] == [(2, bytes([132, 0, 4, 0]))]
    assert parser.crc_errors == 1
    packets = list(parser.feed(good[5:]))  # the truncated tail completes
    assert len(packets) == 1
