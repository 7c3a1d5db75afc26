MODULE SimplePick
  ! Pick and place, two targets
  CONST robtarget pPick := [[600,-200,150],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget pPlace := [[600,200,150],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  PROC main()
    MoveJ Offs(pPick,0,0,100), v1000, z50, tool0;
    MoveL pPick, v200, fine, tool0;
    WaitTime 0.5;
    MoveL Offs(pPick,0,0,100), v500, z10, tool0;
    MoveJ Offs(pPlace,0,0,100), v1000, z50, tool0;
    MoveL pPlace, v200, fine, tool0;
    MoveL Offs(pPlace,0,0,100), v500, z10, tool0;
  ENDPROC
ENDMODULE
