/* The session and link layer (see session.h): what the Python device does in
 * fas/device/session.py, on the chip. */
#include <avr/eeprom.h>
#include <avr/io.h>
#include <avr/pgmspace.h>
#include <string.h>

#include "config.h"
#include "device.h"
#include "frame.h"
#include "inputs.h"
#include "irq.h"
#include "limits.h"
#include "outputs.h"
#include "proto.h"
#include "session.h"
#include "stepgen.h"
#include "ticks.h"
#include "uart.h"

#define TICKS_PER_MS (FW_TICKS_PER_S / 1000UL)

/* ------------------------------------------------------------------ state */
static uint8_t open;            /* a session is open */
static uint16_t nonce;
static uint8_t watchdog_tripped;
static uint8_t estopped;
static uint8_t expected;        /* the sequence number taken next */
static uint16_t watchdog_ms;
static uint32_t watchdog_ticks;
static uint32_t report_ticks;
static uint32_t last_rx_tick;
static uint32_t next_report_tick;
static uint32_t next_status_tick;
static uint8_t refresh_round;
static uint16_t boot_id;
static uint32_t clock_hz;

#define OLD_NONCES 4
static uint16_t old_nonce[OLD_NONCES];
static uint32_t old_nonce_tick[OLD_NONCES];
static uint8_t old_nonce_used;  /* bit per entry */
static uint8_t old_nonce_next;

/* out-of-order frames held until the gap before them is filled */
static struct {
    uint8_t used;
    uint8_t seq;
    uint8_t len;
    uint8_t payload[SLOT_PAYLOAD];
} slots[RX_SLOTS];
static uint8_t held;            /* frames in the slots */

/* ------------------------------------------------------------------ owed output */
static uint8_t ack_due;         /* an acknowledgement is owed; it rides the next report */
static uint8_t ack_now;         /* ... unless the host waits for it */
static uint8_t nak_owed;
static uint8_t ident_due;
static uint16_t ident_nonce;
static uint16_t ident_watchdog_ms;
static uint8_t progress_due;    /* bit per stepper */
static uint8_t dstatus_due;     /* a DeviceStatus in the next report frame */
static struct progress last_progress[FW_MAX_STEPPERS];
static uint8_t last_valid;      /* bit per stepper */

#define SYNC_REPLIES 4
static uint32_t sync_stamp[SYNC_REPLIES];
static uint32_t sync_tick[SYNC_REPLIES];
static uint8_t sync_count;

/* The state as found when it was asked for (Hello, StatusRequest, a stop): Status of
 * every queue and a DeviceStatus, each sent in a frame of its own. */
static uint8_t snap_status[FW_MAX_STEPPERS][SIZE_STATUS];
static uint8_t snap_device[SIZE_DEVICE_STATUS];
static uint8_t snap_queues;     /* bit per Status still to send */
static uint8_t snap_due;        /* the group is to be sent */

static uint8_t out[FRAME_MAX_PAYLOAD];
static uint8_t out_len;

/* ------------------------------------------------------------------ section 18 */
/* Reports of inputs, limit stops and queue starts (issue 13). */
static uint8_t reports_due(void)
{
    return inputs_due() || limits_due() || device_started_due() || outputs_grid_due();
}

static uint8_t reports_put(uint8_t *p, uint8_t room)
{
    uint8_t n = limits_put(p, room);
    n += device_started_put(p + n, room - n);
    n += outputs_grid_put(p + n, room - n);
    return n + inputs_put(p + n, room - n);
}

static void reports_sent(void)
{
    limits_sent();
    device_started_sent();
    outputs_grid_sent();
    inputs_sent();
}

/* ------------------------------------------------------------------ helpers */
static int8_t seq_diff(uint8_t a, uint8_t b)
{
    return (int8_t)(((uint8_t)(a - b + 64) & SEQ_MASK) - 64);
}

static uint8_t state_bits(void)
{
    return (watchdog_tripped ? D_WATCHDOG : 0) | (estopped ? D_ESTOP : 0)
           | (open ? D_SESSION : 0);
}

static void encode_device_status(uint8_t *p)
{
    *p++ = M_DEVICE_STATUS;
    p = put_u32(p, ticks_now());
    *p++ = state_bits();
    counters.crc_errors = frame_crc_errors;
    counters.framing_errors = frame_framing_errors;
    p = put_u32(p, counters.frames_ok);
    p = put_u32(p, counters.entries);
    const uint16_t *c = &counters.frames_duplicate;
    for (uint8_t i = 0; i < 17; i++)
        p = put_u16(p, c[i]);
}

static uint8_t encode_progress(uint8_t *p, uint8_t ch, const struct progress *pr)
{
    p[0] = M_PROGRESS | ch;
    p[1] = pr->flags;
    p[2] = pr->index;
    p[3] = pr->steps_left;
    if (pr->flags & P_HAS_PCNT) {
        put_u16(p + 4, (uint16_t)pr->pcnt);
        return 6;
    }
    return 4;
}

static uint8_t same_progress(const struct progress *a, const struct progress *b)
{
    return a->flags == b->flags && a->index == b->index && a->steps_left == b->steps_left
           && a->pcnt == b->pcnt;
}

/* Status of every configured queue and a DeviceStatus, as they are now. */
static void snapshot_status(void)
{
    snap_queues = 0;
    for (uint8_t ch = 0; ch < FW_MAX_STEPPERS; ch++) {
        if (!devq[ch].configured)
            continue;
        struct progress pr;
        device_progress(ch, &pr);
        last_progress[ch] = pr;
        last_valid |= 1u << ch;
        uint8_t *p = snap_status[ch];
        *p++ = M_STATUS;
        *p++ = ch;
        *p++ = pr.flags;
        *p++ = pr.index;
        *p++ = pr.steps_left;
        p = put_u32(p, (uint32_t)device_position(ch));
        p = put_u32(p, device_pulses(ch));
        p = put_u16(p, devq[ch].underruns);
        put_u16(p, (uint16_t)pr.pcnt);
        snap_queues |= 1u << ch;
    }
    encode_device_status(snap_device);
    snap_due = 1;
}

static void halt_all(void)
{
    device_halt_all(0);
}

static void remember_nonce(uint16_t n, uint32_t now)
{
    old_nonce[old_nonce_next] = n;
    old_nonce_tick[old_nonce_next] = now;
    old_nonce_used |= 1u << old_nonce_next;
    old_nonce_next = (old_nonce_next + 1) % OLD_NONCES;
}

static uint8_t late_copy(uint16_t n, uint32_t now)
{
    for (uint8_t i = 0; i < OLD_NONCES; i++)
        if ((old_nonce_used & (1u << i)) && old_nonce[i] == n
                && now - old_nonce_tick[i] < FW_TICKS_PER_S)
            return 1;
    return 0;
}

/* ------------------------------------------------------------------ init */
void session_init(void)
{
    /* the boot id: a counter in EEPROM, one more at every start */
    inputs_init();
    uint16_t boots = eeprom_read_word((uint16_t *)EE_BOOT_COUNT) + 1;
    eeprom_update_word((uint16_t *)EE_BOOT_COUNT, boots);
    boot_id = boots;
    clock_hz = eeprom_read_dword((uint32_t *)EE_CLOCK_HZ);
    if (clock_hz == 0 || clock_hz == 0xFFFFFFFFUL)
        clock_hz = FW_TICKS_PER_S;
    device_init();
    watchdog_ms = DEFAULT_WATCHDOG_MS;
    watchdog_ticks = (uint32_t)DEFAULT_WATCHDOG_MS * TICKS_PER_MS;
    report_ticks = (uint32_t)DEFAULT_REPORT_MS * TICKS_PER_MS;
}

/* ------------------------------------------------------------------ unsequenced */
static void hello(const uint8_t *m, uint32_t now)
{
    uint16_t n = get_u16(m + 2);
    if (late_copy(n, now)) {
        counters.rejected++;  /* a late copy from a session just ended */
        return;
    }
    uint8_t new_session = n != nonce || !open || watchdog_tripped || estopped;
    uint16_t asked = get_u16(m + 4);
    ident_nonce = n;
    ident_watchdog_ms = new_session ? (asked ? asked : DEFAULT_WATCHDOG_MS) : watchdog_ms;
    ident_due = 1;
    snapshot_status();  /* the state as the new host finds it ... */
    if (!new_session)
        return;
    /* ... then a fresh session: motion stopped, counters from zero */
    memset(&counters, 0, sizeof counters);
    frame_reset_counters();
    if (open && nonce != n)
        remember_nonce(nonce, now);
    nonce = n;
    device_halt_all(1);
    outputs_session();  /* (OutputNext counts from the session's own timed changes) */
    limits_reset();  /* watches and limits belong to the session */
    inputs_reset();
    device_reset_reports();
    open = 1;
    watchdog_tripped = 0;
    estopped = 0;
    device_locked = 0;
    expected = 0;
    for (uint8_t i = 0; i < RX_SLOTS; i++)
        slots[i].used = 0;
    held = 0;
    nak_owed = 0;
    watchdog_ms = ident_watchdog_ms;
    watchdog_ticks = (uint32_t)watchdog_ms * TICKS_PER_MS;
    if (m[6])
        report_ticks = (uint32_t)m[6] * TICKS_PER_MS;
    last_rx_tick = now;
    next_report_tick = now;
    next_status_tick = now + (uint32_t)STATUS_MS * TICKS_PER_MS;
}

static void unsequenced(const uint8_t *m, uint32_t tick)
{
    switch (m[0]) {
    case M_HELLO:
        hello(m, tick);
        break;
    case M_SYNC_REQUEST:
        if (sync_count < SYNC_REPLIES) {
            sync_stamp[sync_count] = get_u32(m + 1);
            sync_tick[sync_count] = tick;
            sync_count++;
        }
        break;
    case M_STATUS_REQUEST:
        snapshot_status();
        break;
    case M_BYE:
        if (open && get_u16(m + 1) == nonce) {
            halt_all();
            open = 0;
            remember_nonce(nonce, tick);
        }
        break;
    case M_ESTOP: {
        uint16_t n = get_u16(m + 1);
        if (n != 0 && !(open && n == nonce)) {
            counters.rejected++;
            break;
        }
        if (!estopped) {
            estopped = 1;
            device_locked = 1;
            halt_all();
        }
        snapshot_status();
        break;
    }
    case M_HALT: {
        uint8_t ch = device_halt(m[1], m[2], open && get_u16(m + 3) == nonce);
        if (ch != 255)
            progress_due |= 1u << ch;
        break;
    }
    default:
        counters.rejected++;
        break;
    }
}

/* ------------------------------------------------------------------ sequenced */
/* The messages of a payload, in order, up to the first one this device does not know
 * or that is cut short (the rest is dropped: `rejected`). */
static void each_message(const uint8_t *payload, uint8_t len, uint8_t sequenced, uint32_t tick)
{
    uint8_t pos = 0;
    while (pos < len) {
        uint8_t size = proto_host_message_size(payload[pos]);
        if (size == 0 || pos + size > len) {
            counters.rejected++;
            return;
        }
        if (sequenced) {
            device_sequenced(payload + pos);
            if (device_report_stepper != 255) {
                progress_due |= 1u << device_report_stepper;
                device_report_stepper = 255;
            }
        } else {
            unsequenced(payload + pos, tick);
        }
        pos += size;
    }
}

static void take(const uint8_t *payload, uint8_t len, uint32_t tick)
{
    expected = (expected + 1) & SEQ_MASK;
    counters.frames_ok++;
    each_message(payload, len, 1, tick);
}

static int8_t slot_of(uint8_t seq)
{
    uint8_t i = seq % RX_SLOTS;
    return (slots[i].used && slots[i].seq == seq) ? (int8_t)i : -1;
}

void session_frame(const struct frame_in *f)
{
    limits_poll();  /* a limit stop the interrupts made comes before any message */
    if (open)
        last_rx_tick = f->tick;
    if (f->seq & SEQ_UNSEQUENCED) {
        each_message(f->payload, f->len, 0, f->tick);
        return;
    }
    if (!open) {
        counters.rejected++;
        dstatus_due = 1;  /* a DeviceStatus without the session bit: the host was reset */
        return;
    }
    int8_t d = seq_diff(f->seq, expected);
    ack_due = 1;
    if (d < 0 || slot_of(f->seq) >= 0) {
        counters.frames_duplicate++;
        ack_now = 1;  /* the host repeats itself: it waits for this */
        nak_owed = held != 0;
        return;
    }
    if (d > 0) {
        /* a gap: hold the frame if it is within the slots, and say what is missing */
        counters.frames_out_of_order++;
        if (!held)
            nak_owed = 1;
        if (d <= RX_SLOTS && f->len <= SLOT_PAYLOAD) {
            uint8_t i = f->seq % RX_SLOTS;
            slots[i].used = 1;
            slots[i].seq = f->seq;
            slots[i].len = f->len;
            memcpy(slots[i].payload, f->payload, f->len);
            held++;
            counters.frames_held++;
        }
        return;
    }
    take(f->payload, f->len, f->tick);
    if (held) {
        int8_t i;
        while ((i = slot_of(expected)) >= 0) {  /* the gap is filled: the held ones follow */
            slots[i].used = 0;
            held--;
            take(slots[i].payload, slots[i].len, f->tick);
        }
        ack_now = 1;
        nak_owed = held != 0;
    }
}

/* ------------------------------------------------------------------ sending */
static uint16_t held_bitmap(void)
{
    uint16_t bits = 0;
    for (uint8_t i = 0; i < RX_SLOTS; i++)
        if (slots[i].used)
            bits |= 1u << ((uint8_t)(slots[i].seq - expected - 1) & SEQ_MASK);
    return bits;
}

/* A new frame's payload: the Nak first while frames are missing. */
static void begin(void)
{
    out_len = 0;
    if (nak_owed || held) {
        out[0] = M_NAK;
        out[1] = expected;
        put_u16(out + 2, held_bitmap());
        out_len = SIZE_NAK;
    }
}

/* Send the frame built in `out`; 0 if the transmit ring has no room for it now. */
static uint8_t send(void)
{
    if (!frame_send(expected, out, out_len))
        return 0;
    ack_due = ack_now = nak_owed = 0;  /* every frame acknowledges */
    return 1;
}

static void ident(void)
{
    uint8_t *p = out + out_len;
    *p++ = M_IDENT;
    *p++ = PROTOCOL_VERSION;
    p = put_u16(p, ident_nonce);
    p = put_u16(p, boot_id);
    p = put_u32(p, FW_TICKS_PER_S);
    p = put_u32(p, clock_hz);
    *p++ = FW_MAX_STEPPERS;
    *p++ = QUEUE_LEN;
    *p++ = RX_SLOTS;
    *p++ = SLOT_PAYLOAD;
    p = put_u16(p, ident_watchdog_ms);
    p = put_u16(p, FW_MIN_CMD_TICKS_DIV);
    p = put_u16(p, F_INPUTS | F_TIMED_OUTPUTS | (inputs_simulated ? F_SIM_INPUTS : 0));
    static const char name[] PROGMEM = FW_NAME;
    *p++ = sizeof name - 1;
    memcpy_P(p, name, sizeof name - 1);
    p += sizeof name - 1;
    out_len = p - out;
}

/* Progress of the queues that changed since their last report (and, `moving`, of
 * those that run or wait for a start). */
static void mark_progress(uint8_t moving)
{
    for (uint8_t ch = 0; ch < FW_MAX_STEPPERS; ch++) {
        if (!devq[ch].configured)
            continue;
        struct progress pr;
        device_progress(ch, &pr);
        if (!(last_valid & (1u << ch)) || !same_progress(&pr, &last_progress[ch])
                || (moving && (pr.flags & (P_RUNNING | P_START_PENDING))))
            progress_due |= 1u << ch;
    }
}

static void flush(void)
{
    if (ident_due) {
        begin();
        ident();
        if (!send())
            return;
        ident_due = 0;
    }
    if (snap_due) {
        for (uint8_t ch = 0; ch < FW_MAX_STEPPERS; ch++) {
            if (!(snap_queues & (1u << ch)))
                continue;
            begin();
            memcpy(out + out_len, snap_status[ch], SIZE_STATUS);
            out_len += SIZE_STATUS;
            if (!send())
                return;
            snap_queues &= (uint8_t)~(1u << ch);
        }
        begin();
        memcpy(out + out_len, snap_device, SIZE_DEVICE_STATUS);
        out_len += SIZE_DEVICE_STATUS;
        if (!send())
            return;
        snap_due = 0;
    }
    if (!(sync_count || progress_due || dstatus_due || (ack_due && ack_now) || nak_owed
          || (open && reports_due())))
        return;
    if (ack_due)
        mark_progress(0);  /* a frame goes out: it tells what changed, too */
    while (sync_count || progress_due || dstatus_due || (ack_due && ack_now) || nak_owed
           || (open && reports_due())) {
        begin();
        uint8_t syncs = 0, queues = 0, device = 0;
        while (syncs < sync_count && out_len + SIZE_SYNC_REPLY <= FRAME_MAX_PAYLOAD) {
            uint8_t *p = out + out_len;
            *p++ = M_SYNC_REPLY;
            p = put_u32(p, sync_stamp[syncs]);
            put_u32(p, sync_tick[syncs]);
            out_len += SIZE_SYNC_REPLY;
            syncs++;
        }
        struct progress pr[FW_MAX_STEPPERS];
        for (uint8_t ch = 0; ch < FW_MAX_STEPPERS; ch++) {
            if (!(progress_due & (1u << ch)) || out_len + SIZE_PROGRESS_MAX > FRAME_MAX_PAYLOAD)
                continue;
            device_progress(ch, &pr[ch]);
            out_len += encode_progress(out + out_len, ch, &pr[ch]);
            queues |= 1u << ch;
        }
        if (dstatus_due && out_len + SIZE_DEVICE_STATUS <= FRAME_MAX_PAYLOAD) {
            encode_device_status(out + out_len);
            out_len += SIZE_DEVICE_STATUS;
            device = 1;
        }
        uint8_t reports = open && reports_due();
        if (reports)
            out_len += reports_put(out + out_len, FRAME_MAX_PAYLOAD - out_len);
        if (!send())
            return;
        if (reports)
            reports_sent();
        /* what went out is done */
        if (syncs) {
            for (uint8_t i = syncs; i < sync_count; i++) {
                sync_stamp[i - syncs] = sync_stamp[i];
                sync_tick[i - syncs] = sync_tick[i];
            }
            sync_count -= syncs;
        }
        for (uint8_t ch = 0; ch < FW_MAX_STEPPERS; ch++) {
            if (queues & (1u << ch)) {
                last_progress[ch] = pr[ch];
                last_valid |= 1u << ch;
            }
        }
        progress_due &= (uint8_t)~queues;
        if (device)
            dstatus_due = 0;
    }
}

/* ------------------------------------------------------------------ time */
void session_poll(void)
{
    uint32_t now = ticks_now();
    if (open && !watchdog_tripped && watchdog_ticks && now - last_rx_tick > watchdog_ticks
            && (int32_t)(now - last_rx_tick) > 0) {
        /* the host has been silent: stop every motion */
        watchdog_tripped = 1;
        device_locked = 1;
        counters.watchdog_trips++;
        halt_all();
        snapshot_status();
    }
    if (open && (int32_t)(now - next_report_tick) >= 0) {
        next_report_tick += report_ticks;
        if ((int32_t)(now - next_report_tick) >= 0)
            next_report_tick = now + report_ticks;
        mark_progress(1);
        ack_now = ack_due;
    }
    if (open && (int32_t)(now - next_status_tick) >= 0) {
        /* the slow refresh: every queue (a lost report heals here), and every few
         * rounds the device state */
        next_status_tick = now + (uint32_t)STATUS_MS * TICKS_PER_MS;
        for (uint8_t ch = 0; ch < FW_MAX_STEPPERS; ch++)
            if (devq[ch].configured)
                progress_due |= 1u << ch;
        inputs_refresh();  /* ... and every watched input */
        if (++refresh_round % DEVICE_STATUS_EVERY == 0)
            dstatus_due = 1;
    }
    flush();
    uart_tx_waiting = session_busy();
}

uint8_t session_busy(void)
{
    return ident_due || snap_due || sync_count || progress_due || dstatus_due
           || (ack_due && ack_now) || nak_owed || (open && reports_due());
}
