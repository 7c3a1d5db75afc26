MODULE Flow
  VAR num nCount := 0;
  VAR bool bDone := FALSE;
  CONST robtarget pA := [[700,0,400],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget pB := [[700,100,400],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  PROC main()
    FOR i FROM 1 TO 3 DO
      MoveL pA, v100, z10, tool0;
      MoveL pB, v100, z10, tool0;
    ENDFOR
    WHILE NOT bDone DO
      nCount := nCount + 1;
      IF nCount > 5 THEN
        bDone := TRUE;
      ELSEIF nCount = 3 THEN
        TPWrite "half way";
      ELSE
        MoveL Offs(pA, 0, 0, nCount * 10), v100, z10, tool0;
      ENDIF
    ENDWHILE
    TEST nCount
    CASE 1, 2:
      MoveL pA, v100, fine, tool0;
    DEFAULT:
      MoveL pB, v100, fine, tool0;
    ENDTEST
    IF nCount > 100 RETURN;
  ENDPROC
ENDMODULE
