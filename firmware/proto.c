/* Sizes of the host's messages (docs/serial-protocol.md, section 5). */
#include "proto.h"

uint8_t proto_host_message_size(uint8_t type)
{
    if ((type & 0xF8) == M_ENTRY)
        return 5;
    switch (type) {
    case M_HELLO: return 7;
    case M_SYNC_REQUEST: return 5;
    case M_CONFIG: return 9;
    case M_DIR_PIN: return 3;
    case M_TRUNCATE: return 3;
    case M_START: return 6;
    case M_FORCE_STOP: return 4;
    case M_SET_END_POS: return 6;
    case M_PIN: return 3;
    case M_DETACH: return 3;
    case M_PCNT_ATTACH: return 9;
    case M_PCNT_CLEAR: return 2;
    case M_STATUS_REQUEST: return 1;
    case M_ESTOP: return 3;
    case M_BYE: return 3;
    case M_HALT: return 5;
    case M_OUTPUT_PWM: return 15;
    case M_OUTPUT_SET: return 8;
    case M_OUTPUT_CANCEL: return 1;
    }
    return 0;
}
