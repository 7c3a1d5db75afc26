MODULE Circles
  CONST robtarget cStart := [[800,0,300],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget cVia := [[850,50,300],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget cEnd := [[900,0,300],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget cVia2 := [[850,-50,300],[0,0,1,0],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  PROC main()
    MoveJ cStart, v500, fine, tool0;
    MoveC cVia, cEnd, v100, z5, tool0;
    MoveC cVia2, cStart, v100, fine, tool0;
    MoveCDO cVia, cEnd, v100, z5, tool0, do1, 1;
  ENDPROC
ENDMODULE
