/* stepperdemo device firmware - the Arduino sketch view of this folder.
 *
 * Open this folder in the Arduino IDE (File > Open > firmware.ino), pick
 * "Arduino Uno" or "Arduino Nano" and upload.  The firmware is plain C in the .c
 * files next to this one; it has its own main() and drives the chip's timers and
 * UART itself, so this sketch has no setup() or loop() and uses nothing of the
 * Arduino core (no Serial, no millis()).  The line speed is BAUD in config.h.
 *
 * README.md explains the wiring and the avrdude command for the same build from a
 * shell (make -C firmware).
 */
