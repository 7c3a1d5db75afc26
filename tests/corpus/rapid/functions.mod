MODULE Functions
  RECORD cutdata
    num depth;
    num feed;
  ENDRECORD
  CONST robtarget pStart := [[500,0,600],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  FUNC num clamp(num v, num lo, num hi)
    IF v < lo RETURN lo;
    IF v > hi RETURN hi;
    RETURN v;
  ENDFUNC
  TRAP onStop
    StopMove;
  ENDTRAP
  PROC main()
    VAR num d;
    d := clamp(3.5, 0, 2);
    MoveJ pStart, v500, fine, tool0;
    MoveL Offs(pStart, 0, 0, -10), v20, fine, tool0;
  ERROR
    RETRY;
  ENDPROC
ENDMODULE
