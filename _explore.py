import numpy as np
import control_ncs as ncs
from control_ncs.lmi import solve
from control_ncs.lmi.worstcase import design_model
from control_ncs.worstcase import supply_levels
A=np.array([[-0.9,0.0],[1.3,1.2]]); B=np.array([[-1.0],[0.3]])
MCL1=[(0,0,1),(0,1,0),(1,0,1)]
P=ncs.ConstrainedPlant.lossy(A,B,np.eye(2),np.eye(2),np.zeros((2,1)),np.zeros((2,2)),MCL1)
lift=P.graph.lift(0)
sup=(-np.eye(2),np.zeros((2,2)),np.zeros((2,2)))
m=design_model(P.A,P.Bu,P.Bw,P.Cz,P.Du,P.Dw,lift.graph.edges,lift.graph.nodes,supply=sup,rate=1.0,common=False,margin=1e-8)
rep=solve(m.problem); print(rep.status, m.level.value, np.sqrt(-m.level.value))
K=m.gains(); X=np.array([x.value for x in m.X]); print(K, X)
loop=P.close(K,lift)
lv,m11,pm=supply_levels(loop,np.linalg.inv(X),*sup); print(lv, np.sqrt(-lv))
r=ncs.worst_case_gain(loop); print(r.figure,r.bound,r.cycle,r.omega)
