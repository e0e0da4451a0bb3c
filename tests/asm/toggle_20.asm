; Toggles P1.0 every 20 machine cycles (50,000 writes per 1,000,000 cycles).
	.area CSEG (ABS,CODE)
	.org 0x0000
loop:	cpl p1.0              ; 1
	mov r7,#8             ; 1
1$:	djnz r7,1$            ; 2 x 8 = 16
	sjmp loop             ; 2
