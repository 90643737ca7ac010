MeshVersionFormatted 2

Dimension 2

SolAtVertices
8
1 3
1 0 1
1 0 1
1 0 1
1 0 1
1 0 1
1 0 1
1 0 1
1 0 1

End
