; Pick and place on an ATmega2560 (sequences/gcode/pick_and_place.toml)
G90 G21 G17 G94         ; the usual preamble of a CAM file
$120=20000              ; X acceleration (steps/s^2)
M64 P1                  ; the "busy" lamp (Dout1) on at once
G0 X2000 Y1500          ; over the part
G1 Z-800 F120000        ; down (Z: stepper 3)
M62 P0                  ; clamp closes when Z is down
M67 E0 Q60              ; and the vacuum pump (Aout0) runs at 60 %
G4 P0.1                 ; let it grip
G1 Z0
G0 X500 Y3000           ; carry it
G1 Z-800
M63 P0                  ; clamp opens when Z is down
M68 E0 Q0               ; pump off at once (the clamp has opened: the parser waited)
G4 P0.1
G1 Z0
G0 X0 Y0                ; home
M65 P1                  ; lamp off
M2
