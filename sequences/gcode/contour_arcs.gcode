; A 2D contour with arcs and tabs (sequences/gcode/contour_arcs.toml): a 40 x 30 mm
; rounded rectangle (corner radius 5 mm) cut 1 mm deep in one pass, climbing to 0.5 mm
; over a 3 mm holding tab in the middle of each long side - as a CAM post writes it.
$100=80                 ; X, Y, Z: 80 steps/mm
$101=80
$102=80
$110=6000               ; 100 mm/s rapids
$111=6000
$112=6000
$120=2000               ; mm/s^2
$121=2000
$122=2000
G90 G21 G17 G94 G54     ; the usual preamble
G10 L2 P1 X10 Y10       ; the part's corner is 10 mm from the machine's origin
$30=24000               ; spindle: full PWM at S24000
M3 S12000               ; spindle on (Aout1): 50 %
M8                      ; flood coolant (Dout3)
G0 Z5
G0 X5 Y0                ; start of the bottom edge
G1 Z-1 F600             ; plunge
G1 X18.5 F1500          ; bottom edge ...
G1 Z-0.5                ; ... tab
G1 X21.5
G1 Z-1
G1 X35
G3 X40 Y5 I0 J5         ; corner (a quarter circle, counter-clockwise)
G1 Y25
G3 X35 Y30 R5           ; corner given by its radius
G1 X21.5                ; top edge ...
G1 Z-0.5                ; ... tab
G1 X18.5
G1 Z-1
G1 X5
G3 X0 Y25 I0 J-5
G1 Y5
G3 X5 Y0 I5 J0          ; back at the start: the contour is closed
G0 Z5
M5 M9
G0 X0 Y0                ; the part's corner (machine 10, 10)
M2
