/PROG  SAMPLE
/ATTR
OWNER		= MNEDITOR;
COMMENT		= "weld seam";
PROG_SIZE	= 0;
LINE_COUNT	= 9;
DEFAULT_GROUP	= 1,*,*,*,*;
/MN
   1:  UFRAME_NUM=0 ;
   2:  UTOOL_NUM=0 ;
   3:J P[1] 100% FINE    ;
   4:L P[2:"approach"] 500mm/sec CNT100    ;
   5:  !seam ;
   6:C P[3]    
    :  P[4] 100mm/sec FINE    ;
   7:L PR[1] 100mm/sec FINE    ;
   8:L P[2] 600cm/min CNT50 Offset,PR[2]    ;
   9:J P[5] 50% FINE    ;
/POS
P[1]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 0, 0',
	X =   900.000  mm,	Y =     0.000  mm,	Z =   300.000  mm,
	W =   180.000 deg,	P =     0.000 deg,	R =     0.000 deg
};
P[2:"approach"]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 0, 0',
	X =   950.000  mm,	Y =   100.000  mm,	Z =   250.000  mm,
	W =   180.000 deg,	P =     0.000 deg,	R =    90.000 deg
};
P[3]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 0, 0',
	X =  1000.000  mm,	Y =   150.000  mm,	Z =   250.000  mm,
	W =   180.000 deg,	P =     0.000 deg,	R =    90.000 deg
};
P[4]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 0, 0',
	X =  1050.000  mm,	Y =   100.000  mm,	Z =   250.000  mm,
	W =   180.000 deg,	P =     0.000 deg,	R =    90.000 deg
};
P[5]{
   GP1:
	UF : 0, UT : 0,	
	J1=    10.000 deg,	J2=    20.000 deg,	J3=   -10.000 deg,
	J4=     0.000 deg,	J5=   -80.000 deg,	J6=     0.000 deg
};
/END
