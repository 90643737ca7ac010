MeshVersionFormatted 2

Dimension 2

SolAtVertices
9
1 2
0.5 0.5
0.5 0.5
0.5 0.5
0.5 0.5
0.5 0.5
0.5 0.5
0.5 0.5
0.5 0.5
0.5 0.5

End
