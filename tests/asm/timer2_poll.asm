; Timer2 in 16-bit auto-reload mode with period PERIOD machine cycles,
; polled with JNB TF2,$: every overflow raises P1.0 for a few cycles.
; P1.5 is never written.
	.area CSEG (ABS,CODE)
	.org 0x0000
PERIOD = 1000
	.globl main, wait
	ljmp main
	.org 0x0030
main:
	mov rcap2h,#>(0x10000-PERIOD)
	mov rcap2l,#<(0x10000-PERIOD)
	mov th2,#>(0x10000-PERIOD)
	mov tl2,#<(0x10000-PERIOD)
	mov t2con,#0x04       ; TR2=1, CP/RL2=0: auto-reload timer
wait:	jnb tf2,wait          ; 2 cycles per poll
	clr tf2               ; 1
	setb p1.0             ; 1   rising edge = end of this instruction
	nop                   ; 1
	nop                   ; 1
	clr p1.0              ; 1   pulse width 3 cycles
	sjmp wait             ; 2
