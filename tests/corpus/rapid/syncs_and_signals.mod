MODULE Signals
  CONST robtarget pGlue1 := [[750,-50,250.25],[0.0436194,0,0.9990482,0],[0,-1,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget pGlue2 := [[750,50,250.25],[0.0436194,0,0.9990482,0],[0,-1,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  PROC glue()
    MoveJ pGlue1, v300, z5, tool0;
    MoveLDO pGlue2, v50, fine, tool0, doGlue, 1;
    SetDO doGlue, 0;
    MoveJDO pGlue1, v300, z5, tool0, doGlue, 0;
  ENDPROC
ENDMODULE
