// stand-in: ArduPilot AP_Logger/LogStructure.h (packet header, the structure table's entry type, the
// message ids), laid out as the real header is: the packet macros, then the libraries' own LogStructure.h
// headers (the generated library's among them, as its integration adds it), then the LogMessages enum
// that lists each library's LOG_IDS_FROM_* ids.
#pragma once
#include <stdint.h>

#define PACKED __attribute__((__packed__))
#define HEAD_BYTE1 0xA3
#define HEAD_BYTE2 0x95
#define LOG_PACKET_HEADER uint8_t head1, head2, msgid;
#define LOG_PACKET_HEADER_INIT(id) head1 : HEAD_BYTE1, head2 : HEAD_BYTE2, msgid : id

#include <AP_DOBWind/LogStructure.h>

struct LogStructure {
    uint8_t msg_type;
    uint8_t msg_len;
    const char *name;
    const char *format;
    const char *labels;
    const char *units;
    const char *multipliers;
    bool streaming; // can be rate limited
};

enum LogMessages : uint8_t {
    LOG_PARAMETER_MSG = 32,
    LOG_MODE_MSG,
    LOG_FORMAT_MSG = 128, // this must remain #128
    LOG_IDS_FROM_DOBWIND,
    _LOG_LAST_MSG_
};
