/* Sizes of the host's messages (docs/serial-protocol.md, section 5). */
#include <avr/pgmspace.h>

#include "proto.h"

/* by type 0x01 .. 0x32 (0: not a host message); in flash, the RAM is for the queues */
#define SIZES_FIRST 0x01
static const uint8_t sizes[] PROGMEM = {
    [M_HELLO - SIZES_FIRST] = 7,
    [M_SYNC_REQUEST - SIZES_FIRST] = 5,
    [M_CONFIG - SIZES_FIRST] = 9,
    [M_DIR_PIN - SIZES_FIRST] = 3,
    [M_TRUNCATE - SIZES_FIRST] = 3,
    [M_START - SIZES_FIRST] = 6,
    [M_FORCE_STOP - SIZES_FIRST] = 4,
    [M_SET_END_POS - SIZES_FIRST] = 6,
    [M_PIN - SIZES_FIRST] = 3,
    [M_DETACH - SIZES_FIRST] = 3,
    [M_PCNT_ATTACH - SIZES_FIRST] = 9,
    [M_PCNT_CLEAR - SIZES_FIRST] = 2,
    [M_STATUS_REQUEST - SIZES_FIRST] = 1,
    [M_ESTOP - SIZES_FIRST] = 3,
    [M_BYE - SIZES_FIRST] = 3,
    [M_HALT - SIZES_FIRST] = 5,
    [M_OUTPUT_PWM - SIZES_FIRST] = 15,
    [M_OUTPUT_SET - SIZES_FIRST] = 8,
    [M_OUTPUT_CANCEL - SIZES_FIRST] = 1,
    [M_OUTPUT_AT - SIZES_FIRST] = 12,
    [M_OUTPUT_NEXT - SIZES_FIRST] = 5,
    [M_WATCH_INPUT - SIZES_FIRST] = 4,
    [M_LIMIT - SIZES_FIRST] = 6,
    [M_SET_INPUT - SIZES_FIRST] = 5,
};

uint8_t proto_host_message_size(uint8_t type)
{
    if ((type & 0xF8) == M_ENTRY)
        return 5;
    uint8_t i = (uint8_t)(type - SIZES_FIRST);
    return i < sizeof sizes ? pgm_read_byte(&sizes[i]) : 0;
}
