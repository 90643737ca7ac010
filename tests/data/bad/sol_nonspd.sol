MeshVersionFormatted 2

Dimension 2

SolAtVertices
9
1 3
1 0 1
1 0 1
1 2 1
1 0 1
1 0 1
1 0 1
1 0 1
1 0 1
1 0 1

End
