MODULE BlockFace
  ! Face-milling pass along the top of a 1000 x 100 x 100 mm block (seed 002's workpiece), as block_face.src:
  ! targets in the block frame, tool z down into the face; confdata of the joints at the written work object.
  PERS tooldata spindle := [TRUE,[[0,0,250],[1,0,0,0]],[20,[0,0,100],[1,0,0,0],0,0,0]];
  TASK PERS wobjdata block := [FALSE,TRUE,"",[[1300,-500,1170],[0.70710678,0,0,0.70710678]],[[0,0,0],[1,0,0,0]]];
  PROC main()
    MoveJ [[0,50,150],[0,0,1,0],[-1,0,-2,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[0,50,100],[0,0,1,0],[-1,0,-2,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[25,50,100],[0,0,1,0],[-1,0,-2,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[50,50,100],[0,0,1,0],[-1,0,-2,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[75,50,100],[0,0,1,0],[-1,0,-2,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[100,50,100],[0,0,1,0],[-1,0,-2,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[125,50,100],[0,0,1,0],[-1,0,-2,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[150,50,100],[0,0,1,0],[-1,0,-2,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[175,50,100],[0,0,1,0],[-1,0,-2,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[200,50,100],[0,0,1,0],[-1,0,-2,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[225,50,100],[0,0,1,0],[-1,0,-2,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[250,50,100],[0,0,1,0],[-1,0,-2,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[275,50,100],[0,0,1,0],[-1,0,-2,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[300,50,100],[0,0,1,0],[-1,0,-2,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[325,50,100],[0,0,1,0],[-1,0,-2,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[350,50,100],[0,0,1,0],[-1,0,-2,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[375,50,100],[0,0,1,0],[-1,0,-2,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[400,50,100],[0,0,1,0],[-1,0,-2,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[425,50,100],[0,0,1,0],[-1,0,-2,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[450,50,100],[0,0,1,0],[-1,0,-2,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[475,50,100],[0,0,1,0],[-1,0,-2,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[500,50,100],[0,0,1,0],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[525,50,100],[0,0,1,0],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[550,50,100],[0,0,1,0],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[575,50,100],[0,0,1,0],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[600,50,100],[0,0,1,0],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[625,50,100],[0,0,1,0],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[650,50,100],[0,0,1,0],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[675,50,100],[0,0,1,0],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[700,50,100],[0,0,1,0],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[725,50,100],[0,0,1,0],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[750,50,100],[0,0,1,0],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[775,50,100],[0,0,1,0],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[800,50,100],[0,0,1,0],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[825,50,100],[0,0,1,0],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[850,50,100],[0,0,1,0],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[875,50,100],[0,0,1,0],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[900,50,100],[0,0,1,0],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[925,50,100],[0,0,1,0],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[950,50,100],[0,0,1,0],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[975,50,100],[0,0,1,0],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[1000,50,100],[0,0,1,0],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
    MoveL [[1000,50,150],[0,0,1,0],[0,0,-1,0],[9E9,9E9,9E9,9E9,9E9,9E9]], v100, fine, spindle\WObj:=block;
  ENDPROC
ENDMODULE
