// stand-in: ArduPilot AP_Logger/LogStructure.h (packet header and the structure table's entry type)
#pragma once
#include <stdint.h>

#define PACKED __attribute__((__packed__))
#define HEAD_BYTE1 0xA3
#define HEAD_BYTE2 0x95
#define LOG_PACKET_HEADER uint8_t head1, head2, msgid;
#define LOG_PACKET_HEADER_INIT(id) head1 : HEAD_BYTE1, head2 : HEAD_BYTE2, msgid : id

struct LogStructure {
    uint8_t msg_type;
    uint8_t msg_len;
    const char *name;
    const char *format;
    const char *labels;
    const char *units;
    const char *multipliers;
};
