MeshVersionFormatted 2
Dimension 2

SolAtVertices
9
1 1
0
0.5
1
1.5
2
2.5
3
3.5
4

SolAtTriangles
8
3 2 1 3
1.5 0 0 2 0.5 1
1.5 1 -1 2 0.5 1
1.5 2 -2 2 0.5 1
1.5 3 -3 2 0.5 1
1.5 4 -4 2 0.5 1
1.5 5 -5 2 0.5 1
1.5 6 -6 2 0.5 1
1.5 7 -7 2 0.5 1

SolAtEdges
8
1 1
0
1
2
3
4
5
6
7

End
