/PROG  T1
/MN
   1:  UFRAME_NUM=0 ;
   2:L P[1] 800mm/sec FINE
    :  Arc Start[6]    ;
   3:  Weave Sine[6] ;
   4:C P[2] Tool_Offset,PR[28]
    :  P[3] WELD_SPEED FINE
    :  Arc End[6]    ;
   5:C P[2]    
    :  P[3] R[23]mm/sec CNT100 Tool_Offset,PR[29]    ;
/POS
P[1]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 0, 0',
	X =   900.000  mm,	Y =     0.000  mm,	Z =   300.000  mm,
	W =   180.000 deg,	P =     0.000 deg,	R =     0.000 deg
};
P[2]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 0, 0',
	X =   950.000  mm,	Y =    50.000  mm,	Z =   300.000  mm,
	W =   180.000 deg,	P =     0.000 deg,	R =     0.000 deg
};
P[3]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 0, 0',
	X =  1000.000  mm,	Y =     0.000  mm,	Z =   300.000  mm,
	W =   180.000 deg,	P =     0.000 deg,	R =     0.000 deg
};
/END
