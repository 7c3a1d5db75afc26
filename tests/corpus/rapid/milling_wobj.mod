MODULE Milling
  ! Fräsbahn über Werkstück - Kommentar mit Umlauten
  PERS tooldata tSpindle := [FALSE,[[0,0,215.5],[1,0,0,0]],[12.5,[0,0,90],[1,0,0,0],0,0,0]];
  PERS tooldata tMill := [TRUE,[[0.25,-0.1,215.5],[1,0,0,0]],[12.5,[0,0,90],[1,0,0,0],0,0,0]];
  TASK PERS wobjdata wTable := [FALSE,TRUE,"",[[1200,-300,400],[0.7071068,0,0,0.7071068]],[[10,20,0],[1,0,0,0]]];
  CONST robtarget p10 := [[0,0,50],[0,0.7071068,0.7071068,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget p20 := [[100,0,-2],[0,0.7071068,0.7071068,0],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget p30 := [[100,100,-2],[0,0.7071068,0.7071068,0],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  CONST robtarget p40 := [[0,100,-2],[0,0.7071068,0.7071068,0],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]];
  PROC main()
    ConfL\Off;
    MoveJ p10, v500, z20, tMill\WObj:=wTable;
    MoveL Offs(p10,0,0,-52), v20, fine, tMill\WObj:=wTable;
    MoveL p20, v50\V:=45, z1, tMill\WObj:=wTable;
    MoveL p30, v50, z1\Z:=0.5, tMill\WObj:=wTable;
    MoveL p40, v50, z1, tMill\WObj:=wTable;
    MoveL Offs(p10,0,0,-52), v50, fine, tMill\WObj:=wTable;
    MoveL p10, v200, z20, tMill\WObj:=wTable;
    ConfL\On;
  ENDPROC
ENDMODULE
