; An OpenBeam Kossel Pro's homedelta.g (RepRapFirmware 1.x/2.x: G1 S1 homes, S2 moves single motors), written for
; deltacal's tests in the shape of github.com/unrepentantgeek/Duet4OBKP 'sys/homedelta.g' (commit
; 09f66a06146c096e02bfeae700befde305053605); licence of the source: none stated; its moves and numbers kept.
G91							; use relative positioning
G1 S1 X400 Y400 Z400 F2500	; move all carriages up 400mm, stopping at the endstops
G1 S2 X-3 Y-3 Z-3			; move all carriages down 3mm
G1 S1 X6 Y6 Z6 F250			; move carriages slowly up 6mm, stopping at the endstops
G1 Z-5 F2000				; down a few mm so that we can centre the head
G90							; back to absolute positioning
G1 X0 Y0 F2000				; centre the head and set a reasonable feed rate
