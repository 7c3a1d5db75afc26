/PROG  WELD_PASS
/ATTR
OWNER		= MNEDITOR;
COMMENT		= "postproc example";
PROG_SIZE	= 0;
DEFAULT_GROUP	= 1,*,*,*,*;
/MN
   1:  UFRAME_NUM=1 ;
   2:  UTOOL_NUM=1 ;
   3:J P[1] 50% FINE    ;
   4:L P[2] 200mm/sec CNT50    ;
   5:L P[3] 200mm/sec CNT50    ;
   6:L P[4] 200mm/sec CNT50    ;
   7:L P[5] 200mm/sec CNT50    ;
   8:L P[6] 200mm/sec CNT50    ;
   9:L P[7] 200mm/sec CNT50    ;
  10:L P[8] 200mm/sec CNT50    ;
  11:L P[9] 200mm/sec CNT50    ;
  12:L P[10] 200mm/sec CNT50    ;
  13:L P[11] 200mm/sec CNT50    ;
  14:L P[12] 200mm/sec CNT50    ;
  15:L P[13] 200mm/sec CNT50    ;
  16:C P[14]    
    :  P[15] 100mm/sec FINE    ;
  17:  !retract ;
  18:L P[16] 500mm/sec FINE    ;
/POS
P[1]{
   GP1:
	UF : 1, UT : 1,		CONFIG : 'N U T, 0, 0, 0',
	X =   900.000  mm,	Y =  -200.000  mm,	Z =   400.000  mm,
	W =  -180.000 deg,	P =     0.000 deg,	R =     0.000 deg
};
P[2]{
   GP1:
	UF : 1, UT : 1,		CONFIG : 'N U T, 0, 0, 0',
	X =   900.000  mm,	Y =  -200.000  mm,	Z =   350.000  mm,
	W =  -180.000 deg,	P =     0.000 deg,	R =     0.000 deg
};
P[3]{
   GP1:
	UF : 1, UT : 1,		CONFIG : 'N U T, 0, 0, 0',
	X =   925.000  mm,	Y =  -190.000  mm,	Z =   350.000  mm,
	W =  -180.000 deg,	P =     0.000 deg,	R =     0.000 deg
};
P[4]{
   GP1:
	UF : 1, UT : 1,		CONFIG : 'N U T, 0, 0, 0',
	X =   950.000  mm,	Y =  -180.000  mm,	Z =   350.000  mm,
	W =  -180.000 deg,	P =     0.000 deg,	R =     0.000 deg
};
P[5]{
   GP1:
	UF : 1, UT : 1,		CONFIG : 'N U T, 0, 0, 0',
	X =   975.000  mm,	Y =  -170.000  mm,	Z =   350.000  mm,
	W =  -180.000 deg,	P =     0.000 deg,	R =     0.000 deg
};
P[6]{
   GP1:
	UF : 1, UT : 1,		CONFIG : 'N U T, 0, 0, 0',
	X =  1000.000  mm,	Y =  -160.000  mm,	Z =   350.000  mm,
	W =  -180.000 deg,	P =     0.000 deg,	R =     0.000 deg
};
P[7]{
   GP1:
	UF : 1, UT : 1,		CONFIG : 'N U T, 0, 0, 0',
	X =  1025.000  mm,	Y =  -150.000  mm,	Z =   350.000  mm,
	W =  -180.000 deg,	P =     0.000 deg,	R =     0.000 deg
};
P[8]{
   GP1:
	UF : 1, UT : 1,		CONFIG : 'N U T, 0, 0, 0',
	X =  1050.000  mm,	Y =  -140.000  mm,	Z =   350.000  mm,
	W =  -180.000 deg,	P =     0.000 deg,	R =     0.000 deg
};
P[9]{
   GP1:
	UF : 1, UT : 1,		CONFIG : 'N U T, 0, 0, 0',
	X =  1075.000  mm,	Y =  -130.000  mm,	Z =   350.000  mm,
	W =  -180.000 deg,	P =     0.000 deg,	R =     0.000 deg
};
P[10]{
   GP1:
	UF : 1, UT : 1,		CONFIG : 'N U T, 0, 0, 0',
	X =  1100.000  mm,	Y =  -120.000  mm,	Z =   350.000  mm,
	W =  -180.000 deg,	P =     0.000 deg,	R =     0.000 deg
};
P[11]{
   GP1:
	UF : 1, UT : 1,		CONFIG : 'N U T, 0, 0, 0',
	X =  1125.000  mm,	Y =  -110.000  mm,	Z =   350.000  mm,
	W =  -180.000 deg,	P =     0.000 deg,	R =     0.000 deg
};
P[12]{
   GP1:
	UF : 1, UT : 1,		CONFIG : 'N U T, 0, 0, 0',
	X =  1150.000  mm,	Y =  -100.000  mm,	Z =   350.000  mm,
	W =  -180.000 deg,	P =     0.000 deg,	R =     0.000 deg
};
P[13]{
   GP1:
	UF : 1, UT : 1,		CONFIG : 'N U T, 0, 0, 0',
	X =  1175.000  mm,	Y =   -90.000  mm,	Z =   350.000  mm,
	W =  -180.000 deg,	P =     0.000 deg,	R =     0.000 deg
};
P[14]{
   GP1:
	UF : 1, UT : 1,		CONFIG : 'N U T, 0, 0, 0',
	X =  1225.000  mm,	Y =   -40.000  mm,	Z =   350.000  mm,
	W =  -180.000 deg,	P =     0.000 deg,	R =     0.000 deg
};
P[15]{
   GP1:
	UF : 1, UT : 1,		CONFIG : 'N U T, 0, 0, 0',
	X =  1200.000  mm,	Y =    20.000  mm,	Z =   350.000  mm,
	W =  -180.000 deg,	P =     0.000 deg,	R =     0.000 deg
};
P[16]{
   GP1:
	UF : 1, UT : 1,		CONFIG : 'N U T, 0, 0, 0',
	X =  1200.000  mm,	Y =    20.000  mm,	Z =   450.000  mm,
	W =  -180.000 deg,	P =     0.000 deg,	R =     0.000 deg
};
/END
