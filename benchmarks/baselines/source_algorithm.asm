; source_algorithm.asm: the source note's 8-servo cycle on P1, transcribed plainly.
;
; AT89C52 at 12 MHz (1 us per machine cycle). Each cycle:
;   1. copy the 8 N (P1.0..P1.7) to 30H-37H and their AND masks to 38H-3FH;
;   2. bubble-sort them from large to small (30H largest), each mask moving
;      with its N;
;   3. take differences: 30H-36H := N(i) - N(i+1), 37H keeps the smallest N;
;   4. raise all 8 lines of P1 together, wait 0.5 ms, then for 37H, 36H, ...
;      30H: delay M x DIV (8 us) with a DJNZ loop and ANL P1 with the mask;
;      the cycles spent fetching M and its mask are deducted from the first
;      DIV of each delay, so edges stay on the 8 us grid;
;   5. wait the 2.8 ms tail with a delay loop and start again.
; Nothing else: a zero difference (equal N, or N = 0 as the smallest) runs
; the DJNZ loop 256 times, and P1 is not driven low at reset.

        .area   CSEG (ABS,CODE)
        .org    0x0000
        ljmp    start

        .org    0x0030
start:
frame:
; 1. take the 8 N and their masks
        mov     dptr,#table
        mov     r0,#0x30
copy:   clr     a
        movc    a,@a+dptr
        mov     @r0,a
        inc     dptr
        inc     r0
        cjne    r0,#0x40,copy

; 2. bubble sort, large to small
        mov     r3,#7               ; passes
pass:   mov     r0,#0x30            ; N(i)
        mov     r1,#0x38            ; mask(i)
        mov     a,r3
        mov     r2,a                ; comparisons in this pass
cmp:    mov     a,@r0
        inc     r0
        clr     c
        subb    a,@r0               ; N(i) - N(i+1)
        jnc     noswap
        mov     a,@r0               ; swap N(i), N(i+1)
        dec     r0
        xch     a,@r0
        inc     r0
        mov     @r0,a
        mov     a,@r1               ; swap mask(i), mask(i+1)
        inc     r1
        xch     a,@r1
        dec     r1
        mov     @r1,a
noswap: inc     r1
        djnz    r2,cmp
        djnz    r3,pass

; 3. differences, large minus small; 37H keeps the smallest N
        mov     r0,#0x30
diff:   mov     a,@r0
        inc     r0
        clr     c
        subb    a,@r0
        dec     r0
        mov     @r0,a
        inc     r0
        cjne    r0,#0x37,diff

; 4. all lines rise, 0.5 ms, then the 8 falling edges
        mov     p1,#0xFF            ; 2  rise
        mov     r6,#249             ; 1
        djnz    r6,.                ; 2 x 249
        nop                         ; 1  -> 500 cycles to the first edge block
; edge 1: M at 37H, mask at 3FH
        mov     r7,0x37          ; 2  fetch M
        mov     a,0x3F           ; 1  its AND mask
        sjmp    d0_in            ; 2  the fetch cycles replace the first DIV's NOPs
d0:     nop                       ; 6 NOPs + DJNZ = 8 cycles = 1 DIV
        nop
        nop
        nop
        nop
        nop
d0_in:  djnz    r7,d0            ; 2  (R7 = 0 on entry: 256 passes)
        anl     p1,a                ; 1  this line falls

; edge 2: M at 36H, mask at 3EH
        mov     r7,0x36          ; 2  fetch M
        mov     a,0x3E           ; 1  its AND mask
        sjmp    d1_in            ; 2  the fetch cycles replace the first DIV's NOPs
d1:     nop                       ; 6 NOPs + DJNZ = 8 cycles = 1 DIV
        nop
        nop
        nop
        nop
        nop
d1_in:  djnz    r7,d1            ; 2  (R7 = 0 on entry: 256 passes)
        anl     p1,a                ; 1  this line falls

; edge 3: M at 35H, mask at 3DH
        mov     r7,0x35          ; 2  fetch M
        mov     a,0x3D           ; 1  its AND mask
        sjmp    d2_in            ; 2  the fetch cycles replace the first DIV's NOPs
d2:     nop                       ; 6 NOPs + DJNZ = 8 cycles = 1 DIV
        nop
        nop
        nop
        nop
        nop
d2_in:  djnz    r7,d2            ; 2  (R7 = 0 on entry: 256 passes)
        anl     p1,a                ; 1  this line falls

; edge 4: M at 34H, mask at 3CH
        mov     r7,0x34          ; 2  fetch M
        mov     a,0x3C           ; 1  its AND mask
        sjmp    d3_in            ; 2  the fetch cycles replace the first DIV's NOPs
d3:     nop                       ; 6 NOPs + DJNZ = 8 cycles = 1 DIV
        nop
        nop
        nop
        nop
        nop
d3_in:  djnz    r7,d3            ; 2  (R7 = 0 on entry: 256 passes)
        anl     p1,a                ; 1  this line falls

; edge 5: M at 33H, mask at 3BH
        mov     r7,0x33          ; 2  fetch M
        mov     a,0x3B           ; 1  its AND mask
        sjmp    d4_in            ; 2  the fetch cycles replace the first DIV's NOPs
d4:     nop                       ; 6 NOPs + DJNZ = 8 cycles = 1 DIV
        nop
        nop
        nop
        nop
        nop
d4_in:  djnz    r7,d4            ; 2  (R7 = 0 on entry: 256 passes)
        anl     p1,a                ; 1  this line falls

; edge 6: M at 32H, mask at 3AH
        mov     r7,0x32          ; 2  fetch M
        mov     a,0x3A           ; 1  its AND mask
        sjmp    d5_in            ; 2  the fetch cycles replace the first DIV's NOPs
d5:     nop                       ; 6 NOPs + DJNZ = 8 cycles = 1 DIV
        nop
        nop
        nop
        nop
        nop
d5_in:  djnz    r7,d5            ; 2  (R7 = 0 on entry: 256 passes)
        anl     p1,a                ; 1  this line falls

; edge 7: M at 31H, mask at 39H
        mov     r7,0x31          ; 2  fetch M
        mov     a,0x39           ; 1  its AND mask
        sjmp    d6_in            ; 2  the fetch cycles replace the first DIV's NOPs
d6:     nop                       ; 6 NOPs + DJNZ = 8 cycles = 1 DIV
        nop
        nop
        nop
        nop
        nop
d6_in:  djnz    r7,d6            ; 2  (R7 = 0 on entry: 256 passes)
        anl     p1,a                ; 1  this line falls

; edge 8: M at 30H, mask at 38H
        mov     r7,0x30          ; 2  fetch M
        mov     a,0x38           ; 1  its AND mask
        sjmp    d7_in            ; 2  the fetch cycles replace the first DIV's NOPs
d7:     nop                       ; 6 NOPs + DJNZ = 8 cycles = 1 DIV
        nop
        nop
        nop
        nop
        nop
d7_in:  djnz    r7,d7            ; 2  (R7 = 0 on entry: 256 passes)
        anl     p1,a                ; 1  this line falls

; 5. the 2.8 ms tail
        mov     r6,#7               ; 1
tail:   mov     r5,#198             ; 1
        djnz    r5,.                ; 2 x 198
        djnz    r6,tail             ; 2  -> 1 + 7 x 399 = 2794
        nop
        nop
        nop
        nop
        ljmp    frame               ; 2  -> 2800 cycles after the last edge

; N of P1.0..P1.7, then the AND mask of each line
table:  .db     0, 1, 125, 125, 200, 249, 250, 60
        .db     0xFE, 0xFD, 0xFB, 0xF7, 0xEF, 0xDF, 0xBF, 0x7F
