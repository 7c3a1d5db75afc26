MODULE ArrayPath
  CONST robtarget path{4} := [
    [[800,-100,200],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]],
    [[800,0,200],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]],
    [[800,100,200],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]],
    [[900,100,200],[0,0,1,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]]];
  PROC main()
    MoveJ path{1}, v500, z10, tool0;
    MoveL path{2}, v100, z1, tool0;
    MoveL path{3}, v100, z1, tool0;
    MoveL path{4}, v100, fine, tool0;
    FOR k FROM 1 TO 4 DO
      MoveL path{k}, v100, z1, tool0;
    ENDFOR
  ENDPROC
ENDMODULE
