"""Frame building blocks shared by the capture generators (scripts/make_*.py, bench/): the check
sums of docs/protocols.md §2-§5 and the byte-log line format (docs/formats.md "The byte log")."""


def crc16(b):
    """Modbus RTU CRC-16 (poly 0xA001, init 0xFFFF) as the two bytes sent, low byte first."""
    c = 0xFFFF
    for x in b:
        c ^= x
        for _ in range(8):
            c = (c >> 1) ^ 0xA001 if c & 1 else c >> 1
    return [c & 0xFF, c >> 8]


def with_crc(b):
    """An RTU frame: the bytes and their CRC."""
    return bytes(b) + bytes(crc16(b))


def lrc(b):
    """Modbus ASCII LRC: two's complement of the byte sum."""
    return (-sum(b)) & 0xFF


def bcc(b):
    """Danfoss FC protocol BCC: XOR of every byte from STX on."""
    x = 0
    for v in b:
        x ^= v
    return x


def fc_telegram(adr, data):
    """Danfoss FC protocol telegram: STX LGE ADR DATA BCC (LGE = data + ADR + BCC)."""
    body = [0x02, len(data) + 2, adr] + list(data)
    return body + [bcc(body)]


def eds_sum(text):
    """Easydrive SUM: 16-bit sum of the ASCII codes, as 4 upper-case hex digits."""
    return f"{sum(text.encode()) & 0xFFFF:04X}"


def ts(ns):
    """A byte-log timestamp: seconds with nine decimals."""
    return f"{ns // 1_000_000_000}.{ns % 1_000_000_000:09d}"


def hexs(b):
    """Bytes (or a str of byte-valued characters) as space-separated hex."""
    return " ".join(f"{(ord(v) if isinstance(v, str) else v):02X}" for v in b)
