MODULE Deburr
  PERS tooldata tBrush := [TRUE,[[50,0,180],[0.9238795,0,0.3826834,0]],[3,[0,0,50],[1,0,0,0],0,0,0]];
  CONST robtarget pEdge := [[650,-100,320.5],[0.5,0.5,0.5,0.5],[-1,0,0,1],[9E9,9E9,9E9,9E9,9E9,9E9]];
  PROC main()
    MoveL RelTool(pEdge, 0, 0, -50), v200, z5, tool0;
    MoveL pEdge, v50, fine, tool0;
    MoveL RelTool(pEdge, 0, 0, -50\Rz:=30), v200, z5, tool0;
  ENDPROC
ENDMODULE
