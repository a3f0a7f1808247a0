import { apiGet } from '@/lib/api-client';
import type { UiConfig } from '@/stores/settingsStore';

export interface Readiness {
  status: 'ready' | 'degraded';
  data: {
    mcp_servers: Record<string, 'connected' | 'connecting' | 'disconnected'>;
    llm: string;
    planner: string | null;
    /** What reads the operator's words, e.g. "rules + embedded matcher" (older brains: absent). */
    planner_understanding?: string | null;
    llm_understanding?: string;
    planner_state?: 'ok' | 'degraded' | null;
    deployment: string;
  };
}

export const fetchReadiness = () => apiGet<Readiness>('/api/readyz');
export const fetchUiConfig = () => apiGet<UiConfig>('/api/ui/config');
