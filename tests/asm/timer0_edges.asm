; Timer0 edges with jitter compensation, the building block of timer-driven
; pulse edges: P1.0 toggles every GAP cycles exactly while the background runs
; MUL, DIV and DJNZ and holds interrupts off for 0, 1, 5 and 10 cycles.
; The handler reads TL0 (cycles since the overflow, entry latency included)
; and enters a NOP slide that far in (PUSH/PUSH/RET: no DPTR), so the edge
; comes a fixed time after the overflow whatever the latency, as long as the
; latency spread fits the slide (SLIDE cycles).
        .area   CSEG (ABS,CODE)
GAP     = 97
SLIDE   = 24
RELOAD  = 0x10000 - (GAP - FIX)
FIX     = 51 - 32 + SLIDE       ; the handler's fixed cycles from overflow to reload (measured)
        .org    0x0000
        ljmp    main
        .org    0x000B
t0_isr: push    psw             ; 2
        push    acc             ; 2
        mov     a, tl0          ; 1  cycles since the overflow, latency included
        add     a, #(slide - X0) ; 1
        push    acc             ; 2  return address low: slide + (TL0 - X0)
        clr     a               ; 1
        push    acc             ; 2  high: page 0
        ret                     ; 2  into the slide
slide:  .rept   SLIDE
        nop
        .endm
        cpl     p1.0            ; 1  the edge, a fixed time after the overflow
        clr     tr0             ; 1
        mov     tl0, #<RELOAD   ; 2
        mov     th0, #>RELOAD   ; 2
        setb    tr0             ; 1
        pop     acc             ; 2
        pop     psw             ; 2
        reti                    ; 2
X0      = 4                     ; the smallest TL0 read: the quickest entry
main:   mov     sp, #0x60
        mov     tmod, #0x01     ; Timer0 16-bit
        mov     tl0, #0xF0
        mov     th0, #0xFF
        setb    et0
        setb    ea
        setb    tr0
bg:     mov     a, #7
        mov     b, #3
        mul     ab
        div     ab
        clr     ea
        setb    ea
        clr     ea
        nop
        setb    ea
        clr     ea
        nop
        nop
        nop
        nop
        nop
        setb    ea
        clr     ea
        .rept   10
        nop
        .endm
        setb    ea
        djnz    r7, bg
        sjmp    bg
