MeshVersionFormatted 2

Dimension 2

SolAtVertices
16
1 1
0.1
0.1
0.1
0.1
0.1
0.1
0.1
0.1
0.1
0.1
0.1
0.1
0.1
0.1
0.1
0.1

End
