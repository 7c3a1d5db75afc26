MODULE Home
  CONST jointtarget jHome := [[0,-20,20,0,90,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST jointtarget jService := [[90,0,0,0,45,-90],[0,9E9,9E9,9E9,9E9,9E9]];
  PROC goHome()
    MoveAbsJ jHome\NoEOffs, v1000, fine, tool0;
  ENDPROC
  PROC service()
    MoveAbsJ jService, v500, fine, tool0;
    Stop;
    MoveAbsJ jHome, v500, fine, tool0;
  ENDPROC
ENDMODULE
