; An RC servo sweep on Aout0 (sequences/gcode/servo_sweep.toml)
$140=50                 ; Aout0 at 50 Hz: timer 1, prescaler 8, TOP 39999 (40000 counts)
M68 E0 Q5               ; 1.0 ms pulse: one end of travel
G4 P0.2
M68 E0 Q6.25
G4 P0.2
M68 E0 Q7.5             ; 1.5 ms: the middle
G4 P0.2
M68 E0 Q8.75
G4 P0.2
M68 E0 Q10              ; 2.0 ms: the other end
G4 P0.2
M68 E0 Q7.5
G4 P0.2
M68 E0 Q5
G4 P0.2
M68 E0 Q0               ; off: the servo goes limp
G4 P0.1                 ; (the off takes effect at the next period's start)
