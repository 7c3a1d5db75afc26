%%%
  VERSION:1
  LANGUAGE:ENGLISH
%%%
MODULE OLDPROG
  CONST robtarget p1:=[[400,0,500],[0.5,0,0.866025,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  PROC main()
    MoveJ p1,v100,z10,tool0;
    MoveL [[420,0,500],[0.5,0,0.866025,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]],v100,fine,tool0;
  ENDPROC
ENDMODULE
