; Measures what the simulator charges for accepting an interrupt.
; P1.0 is cleared by the main program; the first instruction of the
; external-interrupt-0 handler sets it again.  Between the end of
; "clr p1.0" and the end of "setb p1.0" in the handler lie: the
; SETB IE0 that requests the interrupt (1 cycle), the interrupt LCALL
; (2 cycles on an 8051) and the SETB itself (1 cycle).
	.area CSEG (ABS,CODE)
	.org 0x0000
	ljmp main
	.org 0x0003
	setb p1.0
	reti
	.org 0x0030
main:
	setb ex0              ; 1
	setb ea               ; 1
	clr p1.0              ; 1
	setb ie0              ; 1   request INT0 by software
idle:	sjmp idle
